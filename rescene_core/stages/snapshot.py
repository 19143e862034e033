"""Stage ``snapshot``: a foxglove.SceneUpdate of the registered scene (before attachment) on /scene/after_registration."""

from __future__ import annotations

from rescene_core.capture import open_capture
from rescene_core.io import write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.runlog import now_ns, scene_update
from rescene_core.stages.common import load_shell, placed_objects
from rescene_core.stages.execution import executing, make_ref


def run(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    assets: list[Ref],
    poses: list[Ref],
    wall_height: float,
    wall_thickness: float,
) -> Ref:
    """The registered objects in the run log (walls drawn ``wall_height`` x ``wall_thickness`` m) ->
    after_registration.json (their ids)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SNAPSHOT) as seg:
        cap = open_capture(capture.path, validate=False)
        objects = placed_objects(run_dir, cap, assets, poses)
        update = scene_update(objects, load_shell(run_dir, shell), now_ns(), wall_height, wall_thickness)
        seg.log("/scene/after_registration", update)
        write_json_atomic(run.after_registration, {"objects": [o.instance for o in objects]})
        return make_ref(run_dir, run.after_registration, "snapshot", numbers={"objects": len(objects)})
