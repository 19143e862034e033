"""Writing the scene-graph stage's files into a run directory (atomically).

scenegraph/frames/<t>.png   ID-overlay image of key frame t
scenegraph/frames/<t>.json  FramePrediction: prompts, raw answers, validation errors, parsed result
scenegraph/graph.json       edges with V, G, Phi, shell score, omega and flags; node labels; report
scenegraph/graph.png        the graph over the top-down plan
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rescene_core.capture import Capture
from rescene_core.config import SceneGraphConfig
from rescene_core.io import write_bytes_atomic, write_json_atomic
from rescene_core.paths import FRAME_JSON, FRAME_PNG, GRAPH, GRAPH_PNG, SCENEGRAPH, in_folder
from rescene_core.records import RoomShell, SceneGraph
from rescene_core.scenegraph.frame import FramePrediction, render_overlay
from rescene_core.scenegraph.fusion import FusionReport
from rescene_core.scenegraph.overlay import png_bytes
from rescene_core.scenegraph.plot import plot_graph


def write_frame(out_dir: str | Path, capture: Capture, prediction: FramePrediction, config: SceneGraphConfig) -> None:
    """Write ``frames/<t>.json`` and ``frames/<t>.png`` under ``out_dir`` (the run's scenegraph/)."""
    write_json_atomic(in_folder(out_dir, FRAME_JSON, SCENEGRAPH, frame=prediction.frame), prediction.to_json())
    _, image, _ = render_overlay(capture, prediction.frame, config)
    write_bytes_atomic(in_folder(out_dir, FRAME_PNG, SCENEGRAPH, frame=prediction.frame), png_bytes(image))


def graph_json(graph: SceneGraph, capture: Capture, report: FusionReport | None = None) -> dict[str, Any]:
    """graph.json content: the edges, the node labels (for ``prior-refit``) and the fusion report."""
    labels = {str(int(e.child)): capture.instance(int(e.child)).label for e in graph.edges}
    return {
        **graph.to_json(),
        "nodes": labels,
        "scene_id": capture.scene_id,
        "report": None if report is None else report.to_json(),
    }


def write_graph(
    out_dir: str | Path,
    graph: SceneGraph,
    capture: Capture,
    shell: RoomShell | None,
    report: FusionReport | None = None,
) -> Path:
    """Write ``graph.json`` and ``graph.png`` under ``out_dir``; returns the JSON path."""
    path = write_json_atomic(in_folder(out_dir, GRAPH, SCENEGRAPH), graph_json(graph, capture, report))
    write_bytes_atomic(in_folder(out_dir, GRAPH_PNG, SCENEGRAPH), plot_graph(graph, capture, shell))
    return path
