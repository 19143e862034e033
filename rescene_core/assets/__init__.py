"""Single-view asset generation (paper Sec. 3.1 output, Appendix 'Pipeline Variables and Data Flow').

    generate_asset(capture, view, config) -> Asset | Missing     # the chosen view -> a unit-box mesh
    save_asset("asset.glb", asset); load_asset("asset.glb", instance) -> Asset

Backends (``config.backend``): ``lift`` (weight-free, CPU; ``rescene_core.assets.lift``) and ``sam3d``
(SAM 3D Objects on a GPU worker; ``rescene_core.assets.sam3d``, imported only when selected). The
Asset's frame is the backend's own frame normalised to a centred unit box (longest side 1);
``asset_from_generator`` records the normalisation and ``Asset.backend`` which backend ran.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.assets import cache as asset_cache
from rescene_core.assets.base import (
    AssetBackend,
    BackendUnavailable,
    GenerationFailed,
    GeneratorInput,
    GeneratorOutput,
    finish_asset,
    unit_box_normalisation,
)
from rescene_core.config import AssetConfig
from rescene_core.io import write_bytes_atomic
from rescene_core.records import Asset, InstanceId, Missing, Stage, ViewChoice

STAGE = Stage.ASSET

__all__ = [
    "AssetBackend",
    "BackendUnavailable",
    "GenerationFailed",
    "GeneratorInput",
    "GeneratorOutput",
    "finish_asset",
    "generate_asset",
    "load_asset",
    "make_backend",
    "save_asset",
    "unit_box_normalisation",
    "view_input",
]


def make_backend(config: AssetConfig) -> AssetBackend:
    """The configured backend; raises BackendUnavailable naming what is missing."""
    if config.backend == "lift":
        from rescene_core.assets.lift import LiftBackend

        return LiftBackend(config)
    if config.backend == "sam3d":
        from rescene_core.assets.sam3d import Sam3dBackend

        return Sam3dBackend(config)
    raise BackendUnavailable(f"unknown asset backend {config.backend!r} (lift, sam3d)")


def view_input(capture, view: ViewChoice) -> GeneratorInput:
    """The chosen view's rgb, mask, camera and depth (when the capture has it) for ``view.instance``."""
    t = int(view.frame)
    instance = int(view.instance)
    try:
        label = capture.instance(instance).label
    except KeyError:
        label = "object"
    mask = np.asarray(capture.instance_masks[t]) == instance
    depth = None if capture.depth is None else np.asarray(capture.depth[t], dtype=np.float32)
    return GeneratorInput(
        instance=InstanceId(instance),
        label=label,
        frame=t,
        rgb=np.asarray(capture.rgb[t]),
        mask=mask,
        camera=capture.camera(t),
        depth=depth,
    )


def generate_asset(
    capture, view: ViewChoice, config: AssetConfig | None = None, backend: AssetBackend | None = None
) -> Asset | Missing:
    """Generate the asset of ``view.instance`` from its chosen view.

    Returns the Asset (unit-box frame, watertight, metadata with the backend's details), or
    Missing(stage='asset') when the view or the backend cannot give one. A backend that cannot load
    (missing weights or extra) raises BackendUnavailable: that is a configuration error, not an
    instance's failure. ``backend`` overrides the configured one (tests, reuse of a loaded model).
    """
    config = config or AssetConfig()
    instance = InstanceId(int(view.instance))
    if not 0 <= int(view.frame) < capture.num_frames:
        return Missing(instance, STAGE, f"chosen frame {view.frame} is outside 0..{capture.num_frames - 1}")
    vi = view_input(capture, view)
    # the configured backend's assets are kept in the user cache (rescene_core/assets/cache.py); one
    # passed in (a test's, a loaded model's) is not the configured code and is always run
    key = asset_cache.asset_key(vi, config) if backend is None else None
    asset = asset_cache.load_cached(key, instance) if key is not None else None
    if asset is None:
        backend = backend or make_backend(config)
        try:
            out = backend.generate(vi)
            asset = finish_asset(instance, backend.name, out)
        except GenerationFailed as err:
            return Missing(instance, STAGE, f"{backend.name}: {err}")
        if key is not None:
            raw = asset_cache.encode(asset)
            asset = asset_cache.decode(raw, instance) or asset  # a hit and a miss give the same record
            asset_cache.store(key, raw)
    metadata = dict(asset.metadata)
    metadata.setdefault("frame", int(view.frame))
    metadata["view_method"] = view.method
    return Asset(asset.instance, asset.vertices, asset.faces, asset.backend, metadata, asset.asset_from_generator)


def save_asset(path: str | Path, asset: Asset) -> Path:
    """Write the asset as GLB (atomically); backend, metadata and asset_from_generator go in the glTF extras."""
    import trimesh
    from trimesh.exchange.gltf import export_glb

    mesh = trimesh.Trimesh(np.asarray(asset.vertices), np.asarray(asset.faces), process=False)
    scene = trimesh.Scene(mesh)
    scene.metadata["rescene"] = json.loads(
        json.dumps(
            {
                "instance": int(asset.instance),
                "backend": asset.backend,
                "metadata": asset.metadata,
                "asset_from_generator": np.asarray(asset.asset_from_generator).tolist(),
            },
            default=_json_default,
        )
    )
    return write_bytes_atomic(path, export_glb(scene))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot store {type(obj).__name__} in asset metadata")


def load_asset(path: str | Path, instance: int) -> Asset:
    """Read an asset written by ``save_asset`` (or any GLB: backend 'external', identity asset_from_generator)."""
    import trimesh

    loaded = trimesh.load(str(path), process=False)
    extras = dict(getattr(loaded, "metadata", {}) or {}).get("rescene", {})
    mesh = loaded.to_geometry() if isinstance(loaded, trimesh.Scene) else loaded
    if not isinstance(mesh, trimesh.Trimesh):
        raise ValueError(f"{path}: not a triangle mesh ({type(mesh).__name__})")
    return Asset(
        instance=InstanceId(int(instance)),
        vertices=np.asarray(mesh.vertices, dtype=np.float64),
        faces=np.asarray(mesh.faces, dtype=np.int64),
        backend=str(extras.get("backend", "external")),
        metadata=dict(extras.get("metadata", {})),
        asset_from_generator=np.asarray(extras.get("asset_from_generator", np.eye(4)), dtype=np.float64),
    )
