"""The whole pipeline in this process, stage after stage, no orchestration: a notebook's entry point and
the reference the pipeline benchmark compares the Prefect flow with.

Same stages and order as the flow ``rescene`` (flows/scene.py): room shell, view selection, per instance
asset generation and registration, key frames, relations per key frame, fusion, attachment, export and,
when the capture has ground truth, evaluation. Nothing is cached and no run log is written; the export
and the evaluation go to ``out_dir`` (a temporary directory when none is given).
"""

from __future__ import annotations

import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from rescene_core.assembly import AssemblyObject, attach
from rescene_core.assets import generate_asset
from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.config import RunConfig
from rescene_core.evaluation import evaluate_run
from rescene_core.export import ExportConfig, export_scene, placed_objects
from rescene_core.hierview import select_keyframes, select_views
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Layout, Missing, Pose, RoomShell, SceneGraph, Stage
from rescene_core.registration import register
from rescene_core.scenegraph import fuse, make_predictor, predict_frame
from rescene_core.shell import estimate_shell

T = TypeVar("T")


@dataclass(frozen=True)
class PipelineResult:
    """What one in-process run produced.

    poses: the registered pose of every placed instance. layout: the attachment result (None when no
    object was placed). missing: every instance left out, with the stage that left it out.
    metrics: the evaluation (None without ground truth). seconds: wall seconds per stage.
    """

    shell: RoomShell
    poses: dict[InstanceId, Pose]
    graph: SceneGraph
    layout: Layout | None
    missing: tuple[Missing, ...]
    metrics: dict[str, Any] | None
    seconds: dict[Stage, float] = field(default_factory=dict)


def run_pipeline(
    capture_path: str | Path,
    config: RunConfig | None = None,
    out_dir: str | Path | None = None,
    export_config: ExportConfig | None = None,
) -> PipelineResult:
    """Run every stage on ``capture_path`` in sequence; exports (and evaluation) under ``out_dir``."""
    if out_dir is None:
        with tempfile.TemporaryDirectory(prefix="rescene-pipeline-") as tmp:
            return run_pipeline(capture_path, config, tmp, export_config)
    config = config or RunConfig()
    run = RunPaths(out_dir)
    seconds: dict[Stage, float] = defaultdict(float)

    def timed(stage: Stage, fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
        start = time.perf_counter()
        out = fn(*args, **kwargs)
        seconds[stage] += time.perf_counter() - start
        return out

    cap = open_capture(capture_path)
    shell = timed(Stage.SHELL, estimate_shell, cap, config.shell)
    ids = [int(i.id) for i in cap.object_instances]
    views = timed(Stage.VIEW, select_views, cap, config.hierview, instance_ids=ids)
    objects: dict[InstanceId, AssemblyObject] = {}
    poses: dict[InstanceId, Pose] = {}
    missing: list[Missing] = []
    for i in ids:
        view = views.get(i)
        if view is None:
            missing.append(Missing(InstanceId(i), Stage.VIEW, "view selection returned nothing for this instance"))
            continue
        if isinstance(view, Missing):
            missing.append(view)
            continue
        asset = timed(Stage.ASSET, generate_asset, cap, view, config.assets)
        if isinstance(asset, Missing):
            missing.append(asset)
            continue
        pose = timed(Stage.REGISTRATION, register, asset, cap.point_cloud(i), config.registration)
        if isinstance(pose, Missing):
            missing.append(pose)
            continue
        poses[InstanceId(i)] = pose
        objects[InstanceId(i)] = AssemblyObject(
            instance=InstanceId(i),
            label=cap.instance(i).label,
            vertices=asset.vertices,
            faces=asset.faces,
            world_from_asset=pose.world_from_asset,
            points=np.asarray(cap.point_cloud(i).points, np.float64),
        )
    keyframes = timed(Stage.KEYFRAMES, select_keyframes, cap, config.keyframes)
    predictor = make_predictor(config.scenegraph)
    predictions = [
        timed(Stage.RELATIONS, predict_frame, cap, int(t), shell, config.scenegraph, predictor)
        for t in keyframes.frames
    ]
    missing_ids = {int(m.instance) for m in missing}
    graph = timed(Stage.FUSION, fuse, predictions, cap, shell, config.scenegraph, missing_ids)
    layout = timed(Stage.ATTACHMENT, attach, objects, graph, shell, config.attachment) if objects else None
    export_objects = placed_objects(objects.values(), layout)
    layout_missing = list(layout.missing) if layout else []
    timed(
        Stage.EXPORT,
        export_scene,
        run.scene,
        export_objects,
        shell,
        graph,
        sorted(missing, key=lambda m: m.instance) + layout_missing,
        export_config or ExportConfig(),
    )
    metrics = None
    if read_ground_truth(cap) is not None:
        metrics = timed(Stage.EVALUATION, evaluate_run, run.root, capture_path)
    return PipelineResult(shell, poses, graph, layout, tuple(missing), metrics, dict(seconds))
