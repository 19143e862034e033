"""Stage ``shell``: the room shell (floor plane, walls, floor polygon) -> shell.json."""

from __future__ import annotations

from rescene_core.capture import open_capture
from rescene_core.config import ShellConfig
from rescene_core.io import write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.execution import executing, make_ref


def run(run_dir: str, capture: Ref, config: ShellConfig) -> Ref:
    """Room shell -> shell.json."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SHELL) as seg:
        shell = calls.estimate_shell(open_capture(capture.path, validate=False), config)
        write_json_atomic(run.shell, shell.to_json())
        numbers = {"walls": len(shell.walls), "floor_area": float(shell.polygon().area)}
        seg.log("/metrics", {"stage": Stage.SHELL, "metrics": numbers})
        return make_ref(run_dir, run.shell, "shell", numbers=numbers)
