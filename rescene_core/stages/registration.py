"""Stage ``registration``: bounded Sim(3) registration of an asset to its instance's points -> instances/<id>/pose.json."""

from __future__ import annotations

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.io import write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Missing, Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.asset import load_asset_ref
from rescene_core.stages.execution import executing, make_ref, passthrough


def run(run_dir: str, capture: Ref, asset: Ref, config: RegistrationConfig) -> Ref:
    """The registered pose of the instance of ``asset``; a Missing asset passes through."""
    run = RunPaths(run_dir)
    instance = asset.instance
    path = run.pose(instance)
    with executing(run_dir, Stage.REGISTRATION, instance) as seg:
        if asset.missing is not None:
            return passthrough(run_dir, path, "pose", instance, asset.missing)
        cap = open_capture(capture.path, validate=False)
        pose = calls.register(load_asset_ref(run_dir, asset), cap.point_cloud(instance), config)
        if isinstance(pose, Missing):
            seg.log("/registration/gates", {"instance": instance, "method": "none", "diagnostics": pose.to_json()})
            return passthrough(run_dir, path, "pose", instance, pose)
        write_json_atomic(path, {"instance": instance, "status": "ok", "pose": pose.to_json()})
        seg.log(
            "/registration/gates",
            {
                "instance": instance,
                "method": pose.method,
                "world_from_asset": np.asarray(pose.world_from_asset).tolist(),
                "diagnostics": pose.diagnostics,
            },
        )
        numbers = {"scale": sim3.scale_of(pose.world_from_asset)}
        for key in ("rmse", "inlier_ratio", "fitness"):
            if isinstance(pose.diagnostics.get(key), int | float):
                numbers[key] = float(pose.diagnostics[key])
        return make_ref(run_dir, path, "pose", instance, numbers=numbers)
