"""Stage ``relations``: relation inference on one key frame -> scenegraph/frames/<t>.json and its ID overlay <t>.png."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext

from rescene_core.capture import open_capture
from rescene_core.config import SceneGraphConfig
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.common import load_shell
from rescene_core.stages.execution import TransientStageError, executing, make_ref

RequestSlot = Callable[[str], AbstractContextManager[object]]
"""Held around the requests to a VLM endpoint (given its URL): the Prefect tasks hold a slot of a global
concurrency limit shared by every worker; in process, nothing."""


def no_slot(endpoint: str) -> AbstractContextManager[object]:
    """No shared limit on the endpoint's requests."""
    return nullcontext()


def run(
    run_dir: str, capture: Ref, shell: Ref, frame: int, config: SceneGraphConfig, request_slot: RequestSlot = no_slot
) -> Ref:
    """The relation predictor's answer on key frame ``frame``. A transport failure of the endpoint after
    its own retries raises TransientStageError (retried with backoff by the task)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.RELATIONS, frame) as seg:
        cap = open_capture(capture.path, validate=False)
        predictor = calls.make_predictor(config)
        endpoint = str(config.vlm.base_url or "from the environment") if config.backend == "openai" else None
        with request_slot(endpoint) if endpoint is not None else nullcontext():
            prediction = calls.predict_frame(cap, int(frame), load_shell(run_dir, shell), config, predictor)
        transport = [
            a.transport_error for a in getattr(prediction, "attempts", ()) if getattr(a, "transport_error", None)
        ]
        if getattr(prediction, "status", "ok") == "failed" and transport:
            raise TransientStageError(f"key frame {frame}: relation endpoint failed: {transport[-1]}")
        calls.write_frame(run.scenegraph, cap, prediction, config)
        seg.log("/scenegraph/frame_predictions", {"frame": int(frame), "prediction": prediction.to_json()})
        return make_ref(run_dir, run.frame_json(frame), "frame_prediction", int(frame))
