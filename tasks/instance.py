"""Instance tasks: view selection (all instances at once), then asset generation -> registration mapped
over instances.

Each writes ``RUN/instances/<id>/{view,asset,pose}.json`` (and ``asset.glb``) and returns a ``Ref``.
An instance a stage cannot handle comes back as an explicit Missing (status MISSING); later stages
pass it through without calling the library.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import AssetConfig, HierViewConfig, RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.io import hash_file, read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Asset, InstanceId, Missing, Ref, Stage, ViewChoice
from tasks import stages
from tasks.common import executing, make_ref, stage_task


def _passthrough(run_dir: str, path: Path, kind: str, instance: int, missing: Missing) -> Ref:
    write_json_atomic(path, {"instance": instance, "status": "missing", "missing": missing.to_json()})
    return make_ref(run_dir, path, kind, instance, missing=missing)


@stage_task(Stage.VIEW)
def select_views(run_dir: str, capture: Ref, instances: list[int], config: HierViewConfig) -> list[Ref]:
    """HierView for every instance in one call -> instances/<id>/view.json; one reference per instance.

    One task rather than one per instance: HierView shares its per-frame statistics (a pass over every
    mask of every frame) between instances, so per-instance calls would repeat that pass N times; all
    instances have the same inputs (the capture and the config), so nothing is lost for caching.
    """
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.VIEW) as seg:
        cap = open_capture(capture.path, validate=False)
        results = stages.select_views(cap, config, list(instances))
        refs = []
        for instance in instances:
            path = run.view(instance)
            result = results.get(instance)
            if result is None:
                result = Missing(InstanceId(instance), Stage.VIEW, "view selection returned nothing for this instance")
            if isinstance(result, Missing):
                seg.log("/hierview/view_scores", {"instance": instance, "frame": None, "reason": result.reason})
                refs.append(_passthrough(run_dir, path, "view", instance, result))
                continue
            write_json_atomic(path, {"instance": instance, "status": "ok", "view": result.to_json()})
            seg.log(
                "/hierview/view_scores",
                {
                    "instance": instance,
                    "frame": result.frame,
                    "method": result.method,
                    "reason": result.reason,
                    "semantic_backend": result.semantic_backend,
                    "candidates": list(result.candidates),
                },
            )
            numbers = {"frame": result.frame, "candidates": len(result.candidates)}
            refs.append(make_ref(run_dir, path, "view", instance, numbers=numbers))
        return refs


@stage_task(Stage.ASSET, tags=("gpu",))
def generate_asset(run_dir: str, capture: Ref, view: Ref, config: AssetConfig) -> Ref:
    """Asset generation from the chosen view -> instances/<id>/asset.glb + asset.json."""
    run = RunPaths(run_dir)
    instance = view.instance
    path = run.asset_meta(instance)
    with executing(run_dir, Stage.ASSET, instance) as seg:
        if view.missing is not None:
            return _passthrough(run_dir, path, "asset", instance, view.missing)
        choice = ViewChoice.from_json(read_json(run.root / view.path)["view"])
        cap = open_capture(capture.path, validate=False)
        asset = stages.generate_asset(cap, choice, config)
        if isinstance(asset, Missing):
            return _passthrough(run_dir, path, "asset", instance, asset)
        glb = run.asset_glb(instance)
        glb.parent.mkdir(parents=True, exist_ok=True)
        stages.save_asset(glb, asset)
        numbers = {"vertices": int(len(asset.vertices)), "faces": int(len(asset.faces))}
        write_json_atomic(
            path,
            {
                "instance": instance,
                "status": "ok",
                "glb": glb.name,
                "glb_sha256": hash_file(glb),
                "backend": asset.backend,
                "metadata": asset.metadata,
                **numbers,
            },
        )
        seg.log("/assets/generation", {"instance": instance, "backend": asset.backend, **numbers})
        return make_ref(run_dir, path, "asset", instance, numbers=numbers)


def load_asset_ref(run_dir: str, ref: Ref) -> Asset:
    """The Asset behind an asset reference (reads instances/<id>/asset.glb)."""
    run = RunPaths(run_dir)
    meta = read_json(run.root / ref.path)
    return stages.load_asset(run.instance_dir(ref.instance) / meta["glb"], ref.instance)


@stage_task(Stage.REGISTRATION)
def register_instance(run_dir: str, capture: Ref, asset: Ref, config: RegistrationConfig) -> Ref:
    """Bounded Sim(3) registration of the asset to the instance points -> instances/<id>/pose.json."""
    run = RunPaths(run_dir)
    instance = asset.instance
    path = run.pose(instance)
    with executing(run_dir, Stage.REGISTRATION, instance) as seg:
        if asset.missing is not None:
            return _passthrough(run_dir, path, "pose", instance, asset.missing)
        cap = open_capture(capture.path, validate=False)
        pose = stages.register(load_asset_ref(run_dir, asset), cap.point_cloud(instance), config)
        if isinstance(pose, Missing):
            seg.log("/registration/gates", {"instance": instance, "method": "none", "diagnostics": pose.to_json()})
            return _passthrough(run_dir, path, "pose", instance, pose)
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
        scale = sim3.scale_of(pose.world_from_asset)
        numbers = {"scale": scale}
        for key in ("rmse", "inlier_ratio", "fitness"):
            if isinstance(pose.diagnostics.get(key), int | float):
                numbers[key] = float(pose.diagnostics[key])
        return make_ref(run_dir, path, "pose", instance, numbers=numbers)
