"""The assembled scene as a point cloud: ``scene/points.zarr``, surface samples of every placed object.

Layout (the same CSR convention as a capture's ``instances/`` group):

    attrs              format="rescene-scene-points", version, units="m", up="+z", samples_per_m2
    ids      int32   [N]      instance ids, ascending
    offsets  int64   [N + 1]  instance ids[k] owns rows offsets[k]:offsets[k+1]
    points   float32 [M, 3]   world frame, metres, on the placed (attached) meshes
    normals  float32 [M, 3]   unit outward normals of the sampled faces, world frame

Samples are area-uniform, their count proportional to the placed surface area (clamped per object), and
seeded per instance so the same layout gives the same file. Written atomically (temp dir + rename).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh
import zarr

from rescene_core.capture.format import write_array
from rescene_core.export.objects import ExportObject
from rescene_core.geometry import sim3
from rescene_core.io import atomic_directory

if TYPE_CHECKING:
    from rescene_core.config import ExportConfig

POINTS_FORMAT = "rescene-scene-points"
POINTS_VERSION = 1


def sample_object(obj: ExportObject, config: ExportConfig) -> tuple[np.ndarray, np.ndarray]:
    """(points [n, 3], normals [n, 3]) float32 on the object's placed surface, world frame."""
    mesh = trimesh.Trimesh(sim3.apply(obj.world_from_asset, obj.vertices), np.asarray(obj.faces), process=False)
    if len(mesh.faces) == 0 or not np.isfinite(mesh.vertices).all():
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32)
    count = int(
        np.clip(round(mesh.area * config.points_per_m2), config.min_points_per_object, config.max_points_per_object)
    )
    points, faces = trimesh.sample.sample_surface(mesh, count, seed=int(obj.instance))
    return points.astype(np.float32), mesh.face_normals[faces].astype(np.float32)


def write_scene_points(path: str | Path, objects: list[ExportObject], config: ExportConfig) -> Path:
    """Write ``points.zarr`` for the placed objects (see the module docstring)."""
    path = Path(path)
    ordered = sorted(objects, key=lambda o: o.instance)
    samples = [sample_object(o, config) for o in ordered]
    counts = [len(p) for p, _ in samples]
    with atomic_directory(path) as tmp:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        root.attrs.update(
            format=POINTS_FORMAT, version=POINTS_VERSION, units="m", up="+z", samples_per_m2=config.points_per_m2
        )
        write_array(root, "ids", np.array([o.instance for o in ordered], np.int32))
        write_array(root, "offsets", np.concatenate([[0], np.cumsum(counts)]).astype(np.int64))
        empty = np.zeros((0, 3), np.float32)
        write_array(root, "points", np.concatenate([p for p, _ in samples]) if samples else empty)
        write_array(root, "normals", np.concatenate([n for _, n in samples]) if samples else empty)
    return path


def read_scene_points(path: str | Path) -> dict[int, np.ndarray]:
    """Instance id -> float32 [n, 3] world points from a ``points.zarr``."""
    root = zarr.open_group(str(path), mode="r")
    if root.attrs.get("format") != POINTS_FORMAT:
        raise ValueError(f"{path}: not a {POINTS_FORMAT} group (format={root.attrs.get('format')!r})")
    ids, offsets, points = (
        np.asarray(root["ids"][...]),
        np.asarray(root["offsets"][...]),
        np.asarray(root["points"][...]),
    )
    return {int(i): points[offsets[k] : offsets[k + 1]] for k, i in enumerate(ids)}
