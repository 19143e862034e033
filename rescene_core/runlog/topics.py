"""The run log's channels: topic -> JSON schema (name and body), one per kind of decision a stage makes.

Every channel uses JSON message encoding with a ``jsonschema`` schema, so Foxglove Studio and any MCAP
reader can decode it. Scene snapshots use the schema name ``foxglove.SceneUpdate`` so Foxglove's 3D panel
draws them.
"""

from __future__ import annotations

import json
from typing import Any

from rescene_core.runlog.foxglove import SCENE_UPDATE_SCHEMA


def _object_schema(title: str, description: str, properties: dict[str, Any], required: list[str]) -> dict[str, Any]:
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": required,
    }


_INSTANCE = {"type": "integer", "description": "canonical instance id"}
_NUMBERS = {"type": "object", "additionalProperties": {"type": ["number", "string", "boolean", "null"]}}

TOPICS: dict[str, tuple[str, dict[str, Any]]] = {
    "/flow/events": (
        "rescene.FlowEvent",
        _object_schema(
            "rescene.FlowEvent",
            "Flow-level events: start, end, final state, missing instances.",
            {
                "event": {"type": "string"},
                "flow_run_id": {"type": "string"},
                "state": {"type": "string"},
                "message": {"type": "string"},
                "missing": {"type": "array"},
                "details": {"type": "object"},
            },
            ["event"],
        ),
    ),
    "/flow/tasks": (
        "rescene.TaskEvent",
        _object_schema(
            "rescene.TaskEvent",
            "One task run as the flow saw it: stage, item (instance or frame), final state, cached or executed.",
            {
                "stage": {"type": "string"},
                "item": {"type": ["integer", "null"]},
                "state": {"type": "string"},
                "cached": {"type": "boolean"},
                "seconds": {"type": ["number", "null"]},
                "message": {"type": ["string", "null"]},
            },
            ["stage", "state"],
        ),
    ),
    "/task/events": (
        "rescene.TaskExecution",
        _object_schema(
            "rescene.TaskExecution",
            "Written by a task when it actually executes (not when served from cache).",
            {
                "stage": {"type": "string"},
                "item": {"type": ["integer", "null"]},
                "event": {"type": "string"},
                "seconds": {"type": "number"},
                "status": {"type": "string"},
                "error": {"type": ["string", "null"]},
                "pid": {"type": "integer", "description": "process that executed the task"},
                "devices": {
                    "type": "object",
                    "description": "model -> device it ran on (cuda:0, cpu); empty: no torch model",
                },
            },
            ["stage", "event"],
        ),
    ),
    "/hierview/view_scores": (
        "rescene.ViewScores",
        _object_schema(
            "rescene.ViewScores",
            "HierView decision for one instance: chosen frame, method, and every candidate's scores.",
            {
                "instance": _INSTANCE,
                "frame": {"type": ["integer", "null"]},
                "method": {"type": "string"},
                "reason": {"type": "string"},
                "semantic_backend": {"type": "string"},
                "candidates": {"type": "array", "items": {"type": "object"}},
            },
            ["instance"],
        ),
    ),
    "/hierview/keyframes": (
        "rescene.KeyFrames",
        _object_schema(
            "rescene.KeyFrames",
            "Key frames chosen by greedy 3D coverage, with the selector's diagnostics.",
            {"frames": {"type": "array", "items": {"type": "integer"}}, "diagnostics": {"type": "object"}},
            ["frames"],
        ),
    ),
    "/assets/generation": (
        "rescene.AssetGeneration",
        _object_schema(
            "rescene.AssetGeneration",
            "Asset generated for one instance: backend, mesh size.",
            {
                "instance": _INSTANCE,
                "backend": {"type": "string"},
                "vertices": {"type": "integer"},
                "faces": {"type": "integer"},
            },
            ["instance"],
        ),
    ),
    "/registration/gates": (
        "rescene.RegistrationGates",
        _object_schema(
            "rescene.RegistrationGates",
            "Registration of one instance: method, residuals, inlier ratios and every gate decision.",
            {
                "instance": _INSTANCE,
                "method": {"type": "string"},
                "world_from_asset": {"type": "array"},
                "diagnostics": {"type": "object"},
            },
            ["instance"],
        ),
    ),
    "/scenegraph/frame_predictions": (
        "rescene.FramePrediction",
        _object_schema(
            "rescene.FramePrediction",
            "Relations predicted in one key frame (the predictor's validated answer).",
            {"frame": {"type": "integer"}, "prediction": {"type": "object"}},
            ["frame"],
        ),
    ),
    "/scenegraph/fusion": (
        "rescene.FusionScores",
        _object_schema(
            "rescene.FusionScores",
            "One fused edge with its score terms (vote, geometry, category, shell) and flags.",
            {
                "child": _INSTANCE,
                "relation": {"type": "string"},
                "parent": {"type": ["integer", "string"]},
                "confidence": {"type": "number"},
                "scores": _NUMBERS,
                "flags": {"type": "array"},
            },
            ["child"],
        ),
    ),
    "/assembly/operations": (
        "rescene.AttachmentOperation",
        _object_schema(
            "rescene.AttachmentOperation",
            "One attachment operation applied to an instance (rule, transform, ...).",
            {
                "instance": {"type": ["integer", "null"]},
                "rule": {"type": ["string", "null"]},
                "operation": {"type": "object"},
            },
            [],
        ),
    ),
    "/metrics": (
        "rescene.Metrics",
        _object_schema(
            "rescene.Metrics",
            "Named metrics of a stage or of the evaluation.",
            {"stage": {"type": "string"}, "metrics": {"type": "object"}},
            ["stage", "metrics"],
        ),
    ),
    "/scene/after_registration": ("foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
    "/scene/after_attachment": ("foxglove.SceneUpdate", SCENE_UPDATE_SCHEMA),
}
"""Topic -> (schema name, JSON schema)."""


def schema_bytes(topic: str) -> tuple[str, bytes]:
    """(schema name, schema JSON bytes) of a known topic."""
    if topic not in TOPICS:
        raise KeyError(f"unknown run-log topic {topic!r}; topics: {', '.join(sorted(TOPICS))}")
    name, schema = TOPICS[topic]
    return name, json.dumps(schema, sort_keys=True).encode()
