"""Stage ``simcheck``: the physics check of scene/mjcf/scene.xml -> sim/simcheck.json and sim/before_after.png,
and with ``sim.newton`` the same check of scene/scene.usda in Newton -> sim/simcheck-newton.json."""

from __future__ import annotations

from rescene_core.config import SimcheckConfig
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.runlog.writer import Segment
from rescene_core.sim import simcheck_run
from rescene_core.stages.execution import executing, make_ref


def run(run_dir: str, scene: Ref, config: SimcheckConfig) -> Ref:
    """The settled scene's summary; ``scene``: the export's reference (an input so the cache sees it)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SIMCHECK) as seg:
        result = simcheck_run(run_dir, config)
        numbers = result.summary.numbers()
        seg.log("/metrics", {"stage": Stage.SIMCHECK, "metrics": numbers})
        if config.newton:
            _newton(run_dir, config, seg)
        return make_ref(run_dir, run.simcheck, "simcheck", numbers=numbers)


def _newton(run_dir: str, config: SimcheckConfig, seg: Segment) -> None:
    """The second engine beside MuJoCo. A missing ``newton`` extra or a diverged Newton simulation is logged
    (and evaluation says the Newton check was not run) rather than failing the stage whose MuJoCo result
    stands."""
    from rescene_core.sim.newton_check import NewtonUnavailable, newton_simcheck_run

    try:
        record = newton_simcheck_run(run_dir, config)
    except (NewtonUnavailable, RuntimeError) as err:
        RunPaths(run_dir).simcheck_newton.unlink(missing_ok=True)  # never a stale check beside a new scene
        seg.log("/metrics", {"stage": Stage.SIMCHECK, "metrics": {"newton_not_run": str(err)}})
        return
    numbers = {f"newton_{k}": v for k, v in record["summary"].items() if isinstance(v, int | float)}
    numbers["newton_disagreements"] = len(record.get("disagreements", []))
    seg.log("/metrics", {"stage": Stage.SIMCHECK, "metrics": numbers})
