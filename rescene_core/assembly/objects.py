"""The object record the attachment solver works on, its checks, and footprint helpers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray
from shapely.geometry import MultiPoint, Polygon

from rescene_core.geometry.sim3 import apply, check_sim3
from rescene_core.records import InstanceId


class AssemblyError(ValueError):
    """Input the attachment solver cannot work with at all (the message says what and how to fix it)."""


@dataclass(frozen=True, eq=False)
class AssemblyObject:
    """One object to place.

    instance: canonical instance id. label: category label ('bed', 'lamp', ...).
    vertices: float64 [v, 3] mesh vertices in the asset frame. faces: int64 [f, 3] triangle indices.
    world_from_asset: float64 [4, 4] Sim(3), the registered pose T_i (asset frame -> world metres).
    exact_shape: True when the mesh is the object's true shape in a frame aligned with the object (synthetic
        ground truth, CAD models). False (default) for generated assets: their unseen side was completed
        by the generator and their asset axes need not follow the object's faces, so the rules find the
        back face from the mesh faces and treat geometry that crosses the room boundary while the object's
        centre is inside as a completion error, not a pose error (docs/assembly.md, "Generated assets").
    points: float64 [n, 3] world points the capture saw of this object (the registration's P_i), or None.
        Evidence that bounds the solver's moves of a generated asset and gives support planes its mesh
        lacks (``rescene_core.assembly.evidence``); without them those checks are skipped.
    """

    instance: InstanceId
    label: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    world_from_asset: NDArray[np.float64]
    exact_shape: bool = False
    points: NDArray[np.float64] | None = None

    def world_vertices(self, world_from_asset: NDArray | None = None) -> NDArray[np.float64]:
        """Vertices [v, 3] in the world under ``world_from_asset`` (default: the registered pose)."""
        return apply(self.world_from_asset if world_from_asset is None else world_from_asset, self.vertices)

    def mesh(self) -> trimesh.Trimesh:
        """The asset-frame mesh (not processed, so vertex order is kept)."""
        return trimesh.Trimesh(self.vertices, self.faces, process=False)


def check_object(obj: AssemblyObject) -> list[str]:
    """Reasons ``obj`` cannot be placed at all (empty when it can). Non-watertight meshes are allowed."""
    v = np.asarray(obj.vertices)
    f = np.asarray(obj.faces)
    problems: list[str] = []
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4:
        problems.append(f"vertices have shape {v.shape}; need [v >= 4, 3]")
    elif not np.all(np.isfinite(v)):
        problems.append("vertices contain NaN or infinite values")
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] < 1:
        problems.append(f"faces have shape {f.shape}; need [f >= 1, 3]")
    elif v.ndim == 2 and (f.min() < 0 or f.max() >= v.shape[0]):
        problems.append("faces index vertices that do not exist")
    problems += [f"world_from_asset: {p}" for p in check_sim3(obj.world_from_asset)]
    if not problems and np.ptp(v, axis=0).max() <= 0:
        problems.append("mesh has zero extent")
    if obj.points is not None:
        p = np.asarray(obj.points)
        if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
            problems.append(f"points have shape {p.shape} or non-finite values; need finite [n, 3] or None")
    return problems


def is_watertight(obj: AssemblyObject) -> bool:
    """Whether the mesh is closed (containment tests are only run on closed meshes)."""
    return bool(obj.mesh().is_watertight)


def footprint(points_world: NDArray) -> Polygon:
    """Convex footprint of world points [n, 3] on the floor (xy), a shapely Polygon (m)."""
    hull = MultiPoint(np.asarray(points_world)[:, :2]).convex_hull
    if not isinstance(hull, Polygon):  # a degenerate footprint (a line or a point): give it a hair of area
        hull = hull.buffer(1e-4)
    return hull
