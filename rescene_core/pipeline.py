"""The whole pipeline in this process, stage after stage, no orchestration: a notebook's entry point and
the reference the pipeline benchmark compares the Prefect flow with.

It runs ``rescene_core.stages.dag.DAG``, the same stage bodies in the same order as the flow ``rescene``
(flows/scene.py), physics check and evaluation included, and writes the same files under ``out_dir``
(a temporary directory when none is given): instances/, shell.json, keyframes.json, scenegraph/,
layout.json, scene/, sim/, eval/ and the run log. Nothing is cached and no manifest is written (those
belong to the flow). An instance or key frame whose stage raises is left out with a Missing record, like
the flow does; the others go on.
"""

from __future__ import annotations

import logging
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rescene_core.capture import open_capture
from rescene_core.config import RunConfig
from rescene_core.io import read_json
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Layout, Missing, Pose, Ref, RoomShell, SceneGraph, Stage
from rescene_core.runlock import hold_run_directory
from rescene_core.runlog import merge_segments
from rescene_core.stages.dag import DAG, StageSpec
from rescene_core.stages.execution import capture_ref
from rescene_core.stages.keyframes import keyframes_of

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PipelineResult:
    """What one in-process run produced.

    run: the run directory. refs: each stage's result by its name in the DAG (``shell``, ``poses``...).
    poses: the registered pose of every placed instance. layout: the attachment result.
    missing: every instance left out, with the stage that left it out. metrics: eval/metrics.json.
    seconds: wall seconds per stage.
    """

    run: RunPaths
    refs: dict[str, Any]
    shell: RoomShell
    poses: dict[InstanceId, Pose]
    graph: SceneGraph
    layout: Layout
    missing: tuple[Missing, ...]
    metrics: dict[str, Any] | None
    seconds: dict[Stage, float] = field(default_factory=dict)


def _item_of(ref: Any) -> int:
    """The instance (or key frame) a reference or a plain item stands for."""
    return int(ref.instance) if isinstance(ref, Ref) else int(ref)


def _run_over(spec: StageSpec, items: list[Any], kwargs: dict[str, Any], failed: list[Missing]) -> list[Ref]:
    """The stage once per item; an item whose run raises is left out (a per-instance Missing in ``failed``,
    a key frame logged), as the flow leaves out a task that failed after its retries."""
    assert spec.over is not None
    out = []
    for item in items:
        try:
            out.append(spec.run(**kwargs, **{spec.over[1]: item}))
        except Exception as err:  # noqa: BLE001 - one instance's failure must not lose the others' work
            reason = f"{type(err).__name__}: {err}"
            if spec.stage is Stage.RELATIONS:
                log.warning("key frame %s left out of fusion: %s", item, reason)
            else:
                failed.append(Missing(InstanceId(_item_of(item)), spec.stage, reason))
    return out


def run_pipeline(
    capture_path: str | Path, config: RunConfig | None = None, out_dir: str | Path | None = None
) -> PipelineResult:
    """Run every stage of the DAG on ``capture_path`` in sequence, writing the run under ``out_dir``."""
    if out_dir is None:
        with tempfile.TemporaryDirectory(prefix="rescene-pipeline-") as tmp:
            return run_pipeline(capture_path, config, tmp)
    run = RunPaths(Path(out_dir).resolve())
    run.root.mkdir(parents=True, exist_ok=True)
    with hold_run_directory(run.root):  # one run per run directory, as the flow holds it
        return _run_stages(capture_path, config or RunConfig(), run)


def _run_stages(capture_path: str | Path, config: RunConfig, run: RunPaths) -> PipelineResult:
    capture = capture_ref(capture_path)
    cap = open_capture(capture.path, validate=False)
    values: dict[str, Any] = {
        "run_dir": str(run.root),
        "capture": capture,
        "instances": [int(i.id) for i in cap.object_instances],
        "wall_height": config.export.wall_height,
        "wall_thickness": config.export.wall_thickness,
    }
    failed: list[Missing] = []
    seconds: dict[Stage, float] = defaultdict(float)
    for spec in DAG:
        if not spec.enabled(config):
            values[spec.output] = None
            continue
        kwargs = {name: values[name] for name in spec.inputs if name in values}
        if spec.config is not None:
            kwargs["config"] = spec.config_section(config)
        start = time.perf_counter()
        if spec.over is None:
            values[spec.output] = spec.run(**kwargs)
        else:
            kwargs.pop(spec.over[1], None)
            values[spec.output] = _run_over(spec, values[spec.over[0]], kwargs, failed)
        seconds[spec.stage] += time.perf_counter() - start
        _gather(spec.stage, values, failed)
    merge_segments(run.root)
    return _result(run, values, failed, dict(seconds))


def _gather(stage: Stage, values: dict[str, Any], failed: list[Missing]) -> None:
    """The values the flow gathers between stages: after registration, the instances that finished (their
    assets and poses) and every Missing one; after key-frame selection, the key frames."""
    if stage is Stage.REGISTRATION:
        posed = {_item_of(p) for p in values["poses"]}
        values["assets"] = [a for a in values["assets"] if _item_of(a) in posed]
        explicit = [p.missing for p in values["poses"] if p.missing is not None]
        values["missing"] = sorted(failed + explicit, key=lambda m: m.instance)
    elif stage is Stage.KEYFRAMES:
        values["frames"] = keyframes_of(values["run_dir"], values["keyframes"])


def _result(
    run: RunPaths, values: dict[str, Any], failed: list[Missing], seconds: dict[Stage, float]
) -> PipelineResult:
    poses = {
        InstanceId(_item_of(p)): Pose.from_json(read_json(run.root / p.path)["pose"]) for p in values["poses"] if p.ok
    }
    layout = Layout.from_json(read_json(run.layout))
    metrics = read_json(run.metrics) if run.metrics.exists() else None
    return PipelineResult(
        run=run,
        refs=values,
        shell=RoomShell.from_json(read_json(run.shell)),
        poses=poses,
        graph=SceneGraph.from_json(read_json(run.graph)),
        layout=layout,
        missing=tuple(values["missing"]) + tuple(layout.missing),
        metrics=metrics,
        seconds=seconds,
    )
