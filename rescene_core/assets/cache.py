"""Generated assets kept in the user cache (rescene_core/usercache.py, namespace ``assets``).

An asset depends only on its chosen view (the frame's colour, the instance's mask, the depth, the camera,
the label, the instance id and the frame index), the backend's settings and the backend's code, so it is
stored under the hash of exactly those (``asset_key``): a second run of a scene in a fresh run directory,
or a flow whose asset task lost its Prefect result, loads it back in milliseconds instead of generating it
again (the ``lift`` backend spends a fraction of a second an object, SAM 3D Objects seconds to minutes on a
GPU). The code version is the source hash of the import closure of ``rescene_core.assets`` and the backend's
module, so any change to the generator or its helpers misses the old entries. For ``sam3d`` the checkpoint
file's size and modification time join the key (the weights are not hashed: gigabytes).

Only generated assets are kept; a view the backend could not use (``GenerationFailed``) is tried again.
An entry that does not decode is removed and the asset generated and written again.
"""

from __future__ import annotations

import functools
import io
import json
import os
import zipfile
from typing import Any

import numpy as np

from rescene_core.assets.base import GeneratorInput
from rescene_core.config import AssetConfig
from rescene_core.records import Asset, InstanceId
from rescene_core.usercache import UserCache, content_key

NAMESPACE = "assets"
"""The user cache's folder of generated assets."""
SUFFIX = ".npz"
FORMAT_VERSION = 1
"""Bumped when the entry layout changes."""


@functools.cache
def code_version(backend: str) -> str:
    """Source hash of what generates and finishes an asset with ``backend``."""
    from rescene_core.stages.version import source_hash

    return source_hash(["rescene_core.assets", f"rescene_core.assets.{backend}"])


def _weights_stamp(path: str | None) -> Any:
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return {"path": path, "missing": True}
    return {"path": os.path.abspath(path), "size": st.st_size, "mtime_ns": st.st_mtime_ns}


def asset_key(view: GeneratorInput, config: AssetConfig) -> str:
    """sha256 of the view's pixels, depth, camera, label, instance and frame, the asset settings and the
    backend's code version."""
    cam = view.camera
    return content_key(
        "asset",
        FORMAT_VERSION,
        np.asarray(view.rgb, np.uint8),
        np.asarray(view.mask, bool),
        b"" if view.depth is None else np.asarray(view.depth, np.float32),
        np.asarray(cam.K, np.float64),
        np.asarray(cam.world_from_cam, np.float64),
        [int(cam.width), int(cam.height), view.label, int(view.instance), int(view.frame)],
        config.model_dump(mode="json"),
        _weights_stamp(config.sam3d_checkpoint) if config.backend == "sam3d" else None,
        code_version(config.backend),
    )


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot store {type(obj).__name__} in a cached asset's metadata")


def encode(asset: Asset) -> bytes:
    """An npz of the asset: vertices float64 [v, 3], faces int64 [f, 3], asset_from_generator [4, 4] and
    the backend and metadata as JSON."""
    out = io.BytesIO()
    np.savez(
        out,
        vertices=np.asarray(asset.vertices, np.float64),
        faces=np.asarray(asset.faces, np.int64),
        asset_from_generator=np.asarray(asset.asset_from_generator, np.float64),
        meta=json.dumps({"backend": asset.backend, "metadata": asset.metadata}, default=_json_default),
    )
    return out.getvalue()


def decode(raw: bytes, instance: InstanceId) -> Asset | None:
    """The asset of an entry, or None when the entry does not decode."""
    try:
        data = np.load(io.BytesIO(raw))
        meta = json.loads(str(data["meta"]))
        vertices = np.asarray(data["vertices"], np.float64)
        faces = np.asarray(data["faces"], np.int64)
        asset_from_generator = np.asarray(data["asset_from_generator"], np.float64)
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None
    if vertices.ndim != 2 or vertices.shape[1:] != (3,) or faces.ndim != 2 or faces.shape[1:] != (3,):
        return None
    return Asset(instance, vertices, faces, str(meta["backend"]), dict(meta["metadata"]), asset_from_generator)


def load_cached(key: str, instance: InstanceId) -> Asset | None:
    """The cached asset of ``key`` for ``instance``; None on a miss (a corrupt entry is removed)."""
    cache = UserCache(NAMESPACE)
    raw = cache.get(key, SUFFIX)
    if raw is None:
        return None
    asset = decode(raw, instance)
    if asset is None:
        cache.discard(key, SUFFIX)
    return asset


def store(key: str, raw: bytes) -> None:
    """Keep an encoded asset under ``key`` (a read-only or full cache only costs the generation next time)."""
    UserCache(NAMESPACE).put(key, SUFFIX, raw)
