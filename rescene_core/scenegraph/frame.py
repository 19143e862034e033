"""Per-frame relation inference: overlay, prompt, answer, validation and retries for one key frame.

``predict_frame`` returns a ``FramePrediction`` that records every prompt, raw answer, validation
error and the parsed result (``to_json`` -> ``scenegraph/frames/<t>.json``). Relations in the parsed
result use canonical instance ids; ``display_to_instance`` is the frame's mapping.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Literal

from rescene_core.capture import Capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import InstanceId, Parent, Relation, RoomShell, Root, parent_from_json, parent_to_json
from rescene_core.scenegraph.backend import Query, RelationPredictor, TransportError
from rescene_core.scenegraph.overlay import overlay_ids, png_bytes
from rescene_core.scenegraph.prompt import SYSTEM_PROMPT, relation_prompt, relation_schema, retry_prompt
from rescene_core.scenegraph.validate import validate_answer
from rescene_core.scenegraph.view import FrameView, VisibleInstance, frame_view

Status = Literal["ok", "partial", "failed", "empty"]


@dataclass(frozen=True)
class Attempt:
    """One call: the prompt sent, the raw answer, validation errors/warnings, or a transport error."""

    kind: str
    prompt: str
    raw: str | None
    errors: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    transport_error: str | None = None
    seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "prompt": self.prompt,
            "raw": self.raw,
            "errors": list(self.errors),
            "warnings": list(self.warnings),
            "transport_error": self.transport_error,
            "seconds": round(self.seconds, 4),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Attempt:
        return cls(
            str(d["kind"]),
            str(d["prompt"]),
            d.get("raw"),
            tuple(d.get("errors", ())),
            tuple(d.get("warnings", ())),
            d.get("transport_error"),
            float(d.get("seconds", 0.0)),
        )


@dataclass(frozen=True)
class FramePrediction:
    """The relations one key frame predicts, with the full record of how they were obtained.

    visible: instances shown with display ids. relations: canonical child -> (relation, parent), where the
    parent is a canonical instance id or a Root. status: 'ok' (validated), 'partial' (retry budget spent;
    only the entries that passed every per-entry check), 'failed' (nothing usable), 'empty' (nothing
    visible). retries: validation retries used.
    """

    frame: int
    backend: str
    model: str
    visible: tuple[VisibleInstance, ...]
    relations: dict[InstanceId, tuple[Relation, Parent]]
    status: Status
    attempts: tuple[Attempt, ...] = ()
    retries: int = 0
    seconds: float = 0.0
    overlay: tuple[dict[str, Any], ...] = field(default=())

    @property
    def display_to_instance(self) -> dict[int, InstanceId]:
        return {v.display: v.instance for v in self.visible}

    @property
    def usable(self) -> bool:
        """Whether this frame's answer counts in the votes (ok or partial)."""
        return self.status in ("ok", "partial")

    def to_json(self) -> dict[str, Any]:
        return {
            "frame": self.frame,
            "backend": self.backend,
            "model": self.model,
            "status": self.status,
            "retries": self.retries,
            "seconds": round(self.seconds, 4),
            "display_to_instance": {str(k): int(v) for k, v in self.display_to_instance.items()},
            "visible": [v.to_json() for v in self.visible],
            "relations": [
                {"child": int(c), "relation": r.value, "parent": parent_to_json(p)}
                for c, (r, p) in sorted(self.relations.items())
            ],
            "attempts": [a.to_json() for a in self.attempts],
            "overlay": list(self.overlay),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> FramePrediction:
        return cls(
            frame=int(d["frame"]),
            backend=str(d["backend"]),
            model=str(d["model"]),
            visible=tuple(
                VisibleInstance(InstanceId(int(v["instance"])), int(v["display"]), str(v["label"]), int(v["pixels"]))
                for v in d["visible"]
            ),
            relations={
                InstanceId(int(r["child"])): (Relation(r["relation"]), parent_from_json(r["parent"]))
                for r in d["relations"]
            },
            status=d["status"],
            attempts=tuple(Attempt.from_json(a) for a in d.get("attempts", ())),
            retries=int(d.get("retries", 0)),
            seconds=float(d.get("seconds", 0.0)),
            overlay=tuple(d.get("overlay", ())),
        )


def _to_canonical(entries, view: FrameView) -> dict[InstanceId, tuple[Relation, Parent]]:
    mapping = view.display_to_instance
    out: dict[InstanceId, tuple[Relation, Parent]] = {}
    for e in entries:
        parent = Root(e["parent"]) if isinstance(e["parent"], str) else mapping[int(e["parent"])]
        out[mapping[int(e["id"])]] = (Relation(e["relation"]), parent)
    return out


_LAST_OVERLAY = threading.local()
"""Each thread's last ``render_overlay`` call: ((capture, frame, config), result)."""


def render_overlay(capture: Capture, frame: int, config: SceneGraphConfig):
    """(FrameView, PIL overlay image, placements) of one frame; the caller saves the image as frames/<t>.png.

    A thread's last result is returned again for the same capture object, frame and config: the relation
    stage renders a key frame's overlay to ask the predictor (``predict_frame``) and then to save it
    (``write_frame``), and the second rendering was the same pixels (about 0.1 s a 640x480 frame)."""
    last = getattr(_LAST_OVERLAY, "value", None)
    if last is not None and last[0][0] is capture and last[0][1] == int(frame) and last[0][2] == config:
        return last[1]
    view = frame_view(capture, frame, config)
    image, placements = overlay_ids(view, config.overlay_font_px)
    result = (view, image, placements)
    _LAST_OVERLAY.value = ((capture, int(frame), config), result)
    return result


def predict_frame(
    capture: Capture,
    frame: int,
    shell: RoomShell | None,
    config: SceneGraphConfig,
    predictor: RelationPredictor,
) -> FramePrediction:
    """Ask ``predictor`` for the relations of every instance visible in ``frame``, validating and retrying.

    Up to ``config.vlm.retry_budget`` validation retries, each with the errors and the previous answer in the
    prompt. A transport failure (after the backend's own retries) ends the frame with status 'failed'.
    """
    start = time.perf_counter()
    view, image, placements = render_overlay(capture, frame, config)
    overlay = tuple(
        {"display": p.display, "box": list(p.box), "inside_mask": p.inside_mask, "overlaps": p.overlaps}
        for p in placements
    )
    if not view.visible:
        return FramePrediction(frame, predictor.backend, predictor.model, (), {}, "empty", overlay=overlay)
    categories = view.categories
    image_png = png_bytes(image)
    schema = relation_schema(list(categories))
    base = relation_prompt(categories)
    prompt = base
    attempts: list[Attempt] = []
    best = None
    status: Status = "failed"
    for k in range(config.vlm.retry_budget + 1):
        t0 = time.perf_counter()
        query = Query("relations", SYSTEM_PROMPT, prompt, image_png, schema, view, capture, shell)
        try:
            raw = predictor.answer(query)
        except TransportError as err:
            attempts.append(
                Attempt(
                    "initial" if k == 0 else "retry",
                    prompt,
                    None,
                    transport_error=str(err),
                    seconds=time.perf_counter() - t0,
                )
            )
            break
        result = validate_answer(raw, categories, config.vlm.min_id_coverage)
        attempts.append(
            Attempt(
                "initial" if k == 0 else "retry",
                prompt,
                raw,
                result.errors,
                result.warnings,
                seconds=time.perf_counter() - t0,
            )
        )
        if best is None or len(result.entries) > len(best.entries):
            best = result
        if result.ok:
            best, status = result, "ok"
            break
        prompt = retry_prompt(base, raw, list(result.errors))
    if status != "ok" and best is not None and best.entries:
        status = "partial"
    relations = _to_canonical(best.entries, view) if best is not None and status != "failed" else {}
    retries = sum(1 for a in attempts if a.kind == "retry")
    return FramePrediction(
        frame,
        predictor.backend,
        predictor.model,
        view.visible,
        relations,
        status,
        tuple(attempts),
        retries,
        time.perf_counter() - start,
        overlay,
    )


def predict_frames(
    capture: Capture,
    frames: list[int],
    shell: RoomShell | None,
    config: SceneGraphConfig,
    predictor: RelationPredictor,
) -> list[FramePrediction]:
    """``predict_frame`` over several frames, at most ``config.vlm.max_concurrency`` at a time, in frame order."""
    workers = max(1, min(config.vlm.max_concurrency, len(frames)))
    if workers == 1:
        return [predict_frame(capture, t, shell, config, predictor) for t in frames]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(lambda t: predict_frame(capture, t, shell, config, predictor), frames))
