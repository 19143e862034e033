"""Stage ``simcheck``: the physics check of scene/mjcf/scene.xml -> sim/simcheck.json and sim/before_after.png."""

from __future__ import annotations

from rescene_core.config import SimcheckConfig
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.sim import simcheck_run
from rescene_core.stages.execution import executing, make_ref


def run(run_dir: str, scene: Ref, config: SimcheckConfig) -> Ref:
    """The settled scene's summary; ``scene``: the export's reference (an input so the cache sees it)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SIMCHECK) as seg:
        result = simcheck_run(run_dir, config)
        numbers = result.summary.numbers()
        seg.log("/metrics", {"stage": Stage.SIMCHECK, "metrics": numbers})
        return make_ref(run_dir, run.simcheck, "simcheck", numbers=numbers)
