"""Stage ``evaluation``: every metric the run allows -> eval/metrics.json, report.md, report.html."""

from __future__ import annotations

from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation.run import start_scene_metrics
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.stages import hooks
from rescene_core.stages.execution import executing, make_ref


def run(run_dir: str, capture: Ref, scene: Ref, keyframes: Ref | None = None, physics: Ref | None = None) -> Ref:
    """Structural, geometry and rendering metrics against the sensor's depth and the ground truth when the
    capture has them, and the physics check's results. ``scene``, ``keyframes`` and ``physics``
    (sim/simcheck.json) are inputs so the cache sees them."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.EVALUATION) as seg:
        metrics = evaluate_run(run_dir, capture.path)
        flat = {k: v for k, v in metrics.get("summary", {}).items() if isinstance(v, int | float)}
        seg.log("/metrics", {"stage": Stage.EVALUATION, "metrics": flat})
        return make_ref(run_dir, run.metrics, "metrics", numbers=flat)


def start_early(run_dir: str, capture: str) -> None:
    """The evaluation's geometry and rendering metrics, started as soon as the export has written the visual
    scene (``hooks.VISUAL_SCENE_WRITTEN``); ``run`` takes them when it reads the same files."""
    start_scene_metrics(run_dir, capture)


if start_early not in hooks.VISUAL_SCENE_WRITTEN:
    hooks.VISUAL_SCENE_WRITTEN.append(start_early)
