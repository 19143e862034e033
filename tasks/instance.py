"""Instance tasks: view selection (all instances at once), then asset generation -> registration mapped
over instances.

Each writes ``RUN/instances/<id>/{view,asset,pose}.json`` (and ``asset.glb``) and returns a reference.
An instance a stage cannot handle comes back as an explicit Missing (status "missing"); later stages
pass it through without calling the library.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import AssetConfig, HierViewConfig, RegistrationConfig
from rescene_core.io import hash_file, read_json, write_json_atomic
from rescene_core.records import Asset, InstanceId, Missing, ViewChoice
from tasks import stages
from tasks.common import executing, make_ref, ref_missing, stage_task


def instance_dir(instance: int) -> str:
    return f"instances/{int(instance)}"


def _passthrough(run_dir: str, rel: str, kind: str, instance: int, missing: Missing) -> dict[str, Any]:
    write_json_atomic(Path(run_dir) / rel, {"instance": instance, "status": "missing", "missing": missing.to_json()})
    return make_ref(run_dir, rel, kind, instance, status="missing", missing=missing)


@stage_task("view")
def select_views(
    run_dir: str, capture: dict[str, Any], instances: list[int], config: HierViewConfig
) -> list[dict[str, Any]]:
    """HierView for every instance in one call -> instances/<id>/view.json; one reference per instance.

    One task rather than one per instance: HierView shares its per-frame statistics (a pass over every
    mask of every frame) between instances, so per-instance calls would repeat that pass N times; all
    instances have the same inputs (the capture and the config), so nothing is lost for caching.
    """
    with executing(run_dir, "view") as seg:
        cap = open_capture(capture["path"], validate=False)
        results = stages.select_views(cap, config, list(instances))
        refs = []
        for instance in instances:
            rel = f"{instance_dir(instance)}/view.json"
            result = results.get(instance)
            if result is None:
                result = Missing(InstanceId(instance), "view", "view selection returned nothing for this instance")
            if isinstance(result, Missing):
                seg.log("/hierview/view_scores", {"instance": instance, "frame": None, "reason": result.reason})
                refs.append(_passthrough(run_dir, rel, "view", instance, result))
                continue
            write_json_atomic(Path(run_dir) / rel, {"instance": instance, "status": "ok", "view": result.to_json()})
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
            refs.append(make_ref(run_dir, rel, "view", instance, numbers=numbers))
        return refs


@stage_task("asset", tags=("gpu",))
def generate_asset(run_dir: str, capture: dict[str, Any], view: dict[str, Any], config: AssetConfig) -> dict[str, Any]:
    """Asset generation from the chosen view -> instances/<id>/asset.glb + asset.json."""
    instance = int(view["item"])
    rel = f"{instance_dir(instance)}/asset.json"
    with executing(run_dir, "asset", instance) as seg:
        if (missing := ref_missing(view)) is not None:
            return _passthrough(run_dir, rel, "asset", instance, missing)
        choice = ViewChoice.from_json(read_json(Path(run_dir) / view["path"])["view"])
        cap = open_capture(capture["path"], validate=False)
        asset = stages.generate_asset(cap, choice, config)
        if isinstance(asset, Missing):
            return _passthrough(run_dir, rel, "asset", instance, asset)
        glb = Path(run_dir) / instance_dir(instance) / "asset.glb"
        glb.parent.mkdir(parents=True, exist_ok=True)
        stages.save_asset(glb, asset)
        numbers = {"vertices": int(len(asset.vertices)), "faces": int(len(asset.faces))}
        write_json_atomic(
            Path(run_dir) / rel,
            {
                "instance": instance,
                "status": "ok",
                "glb": "asset.glb",
                "glb_sha256": hash_file(glb),
                "backend": asset.backend,
                "metadata": asset.metadata,
                **numbers,
            },
        )
        seg.log("/assets/generation", {"instance": instance, "backend": asset.backend, **numbers})
        return make_ref(run_dir, rel, "asset", instance, numbers=numbers)


def load_asset_ref(run_dir: str, ref: dict[str, Any]) -> Asset:
    """The Asset behind an asset reference (reads instances/<id>/asset.glb)."""
    instance = int(ref["item"])
    meta = read_json(Path(run_dir) / ref["path"])
    return stages.load_asset(Path(run_dir) / instance_dir(instance) / meta["glb"], InstanceId(instance))


@stage_task("registration")
def register_instance(
    run_dir: str, capture: dict[str, Any], asset: dict[str, Any], config: RegistrationConfig
) -> dict[str, Any]:
    """Bounded Sim(3) registration of the asset to the instance points -> instances/<id>/pose.json."""
    instance = int(asset["item"])
    rel = f"{instance_dir(instance)}/pose.json"
    with executing(run_dir, "registration", instance) as seg:
        if (missing := ref_missing(asset)) is not None:
            return _passthrough(run_dir, rel, "pose", instance, missing)
        cap = open_capture(capture["path"], validate=False)
        pose = stages.register(load_asset_ref(run_dir, asset), cap.point_cloud(instance), config)
        if isinstance(pose, Missing):
            seg.log("/registration/gates", {"instance": instance, "method": "none", "diagnostics": pose.to_json()})
            return _passthrough(run_dir, rel, "pose", instance, pose)
        write_json_atomic(Path(run_dir) / rel, {"instance": instance, "status": "ok", "pose": pose.to_json()})
        seg.log(
            "/registration/gates",
            {
                "instance": instance,
                "method": pose.method,
                "world_from_asset": np.asarray(pose.world_from_asset).tolist(),
                "diagnostics": pose.diagnostics,
            },
        )
        scale = float(np.cbrt(abs(np.linalg.det(np.asarray(pose.world_from_asset)[:3, :3]))))
        numbers = {"scale": scale}
        for key in ("rmse", "inlier_ratio", "fitness"):
            if isinstance(pose.diagnostics.get(key), int | float):
                numbers[key] = float(pose.diagnostics[key])
        return make_ref(run_dir, rel, "pose", instance, numbers=numbers)
