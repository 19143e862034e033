"""Stage ``asset``: asset generation from an instance's chosen view -> instances/<id>/asset.glb + asset.json."""

from __future__ import annotations

from pathlib import Path

from rescene_core.capture import open_capture
from rescene_core.config import AssetConfig
from rescene_core.io import hash_file, read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Asset, Missing, Ref, Stage, ViewChoice
from rescene_core.stages import calls
from rescene_core.stages.execution import executing, make_ref, passthrough


def run(run_dir: str, capture: Ref, view: Ref, config: AssetConfig) -> Ref:
    """The generated asset of the instance of ``view``; a Missing view passes through."""
    run = RunPaths(run_dir)
    instance = view.instance
    path = run.asset_meta(instance)
    with executing(run_dir, Stage.ASSET, instance) as seg:
        if view.missing is not None:
            return passthrough(run_dir, path, "asset", instance, view.missing)
        choice = ViewChoice.from_json(read_json(run.root / view.path)["view"])
        cap = open_capture(capture.path, validate=False)
        asset = calls.generate_asset(cap, choice, config)
        if isinstance(asset, Missing):
            return passthrough(run_dir, path, "asset", instance, asset)
        glb = run.asset_glb(instance)
        glb.parent.mkdir(parents=True, exist_ok=True)
        calls.save_asset(glb, asset)
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


def load_asset_ref(run_dir: str | Path, ref: Ref) -> Asset:
    """The Asset behind an asset reference (reads instances/<id>/asset.glb)."""
    run = RunPaths(run_dir)
    meta = read_json(run.root / ref.path)
    return calls.load_asset(run.instance_dir(ref.instance) / meta["glb"], ref.instance)
