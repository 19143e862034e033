"""Geometric prior G_k and room-shell prior of candidate edges, from instance point clouds P_i.

Fusion runs before and independently of registration, so these use the capture's point clouds, not
meshes. Every score is in [0, 1].

- floor parent: floor contact = exp(-(gap / floor_sigma)^2) x fraction of the footprint inside the floor
  polygon, gap = |height of the lower contact surface above the floor plane|;
- wall parent: wall alignment = max over walls of exp(-(residual / wall_sigma)^2) x normal agreement x
  lateral fraction, residual = distance of the back surface to the wall plane, normal agreement = how
  well the footprint's minimum-area rectangle lines up with the wall (cos 2 delta, clipped at 0);
- object parent: support = exp(-(gap / support_sigma)^2) x the fraction of the child's contact footprint
  above an upward-facing face of the parent at the child's bottom height.

Room-shell prior: floor = touches x inside; wall = (1 - touches) x near a wall; object = (1 - touches)
x inside, with touches = exp(-(gap / floor_sigma)^2): the structure says whether the child stands on the
floor, hangs by a wall or is held above the floor by something.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from shapely.geometry import MultiPoint

from rescene_core.capture import Capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import InstanceId, Parent, RoomShell, Root
from rescene_core.scenegraph.geom import heights, lower_surface, upper_surface, upward_mask, wall_fit

CONTACT_BAND_RATIO = 0.2
"""The contact footprint is the child's points within max(support_tol, this x its height) of its bottom."""
POLYGON_TOLERANCE = 0.05
"""Points this far outside the floor polygon still count as inside (m)."""


@dataclass(frozen=True)
class InstanceGeometry:
    """Per-instance quantities of P_i the priors need.

    points: float64 [n, 3] world metres (subsampled). height: [n] above the floor plane.
    upward: bool [n], points whose estimated normal is within upward_normal_deg of vertical.
    bottom, top: robust lowest / highest height (m). inside: fraction of points inside the floor polygon.
    yaw: orientation of the footprint's minimum-area rectangle (rad), or None when degenerate.
    """

    instance: InstanceId
    points: NDArray[np.float64]
    height: NDArray[np.float64]
    upward: NDArray[np.bool_]
    bottom: float
    top: float
    inside: float
    yaw: float | None

    @property
    def empty(self) -> bool:
        return len(self.points) == 0


def _yaw(xy: NDArray) -> float | None:
    rect = MultiPoint(xy).minimum_rotated_rectangle
    if rect.geom_type != "Polygon":
        return None
    c = np.asarray(rect.exterior.coords)
    e = c[1] - c[0]
    return float(np.arctan2(e[1], e[0])) if np.linalg.norm(e) > 1e-9 else None


def instance_geometry(
    capture: Capture, instance: int, shell: RoomShell, config: SceneGraphConfig, seed: int = 0
) -> InstanceGeometry:
    """Measure P_i of one instance against the shell (at most ``max_fusion_points`` points)."""
    pts = np.asarray(capture.point_cloud(instance).points, dtype=np.float64)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) > config.max_fusion_points:
        pts = pts[np.random.default_rng(seed + int(instance)).choice(len(pts), config.max_fusion_points, replace=False)]
    iid = InstanceId(int(instance))
    if len(pts) < 3:
        return InstanceGeometry(
            iid, pts.reshape(-1, 3), np.zeros(len(pts)), np.zeros(len(pts), bool), np.inf, -np.inf, 0.0, None
        )
    h = heights(shell, pts)
    upward = upward_mask(pts, shell, config.normal_neighbours, config.upward_normal_deg)
    polygon = shell.polygon().buffer(POLYGON_TOLERANCE) if len(shell.floor_polygon) >= 3 else None
    inside = float(shapely.contains_xy(polygon, pts[:, 0], pts[:, 1]).mean()) if polygon is not None else 1.0
    return InstanceGeometry(
        iid,
        pts,
        h,
        upward,
        lower_surface(h),
        upper_surface(h),
        inside,
        _yaw(pts[:, :2]),
    )


def _gauss(x: float, sigma: float) -> float:
    return float(np.exp(-((x / sigma) ** 2))) if np.isfinite(x) else 0.0


def floor_contact(child: InstanceGeometry, config: SceneGraphConfig) -> float:
    """G for (child, rests-on, floor)."""
    if child.empty:
        return 0.0
    return _gauss(abs(child.bottom), config.floor_sigma) * child.inside


def wall_alignment(child: InstanceGeometry, shell: RoomShell, config: SceneGraphConfig) -> tuple[float, int | None]:
    """G for (child, mounts-on, wall): best over walls, and that wall's id."""
    best, best_id = 0.0, None
    if child.empty:
        return best, best_id
    for wall in shell.walls:
        residual, lateral = wall_fit(child.points, wall)
        if child.yaw is None:
            agree = 1.0
        else:
            wall_yaw = np.arctan2(wall.plane.normal[1], wall.plane.normal[0])
            delta = abs((wall_yaw - child.yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)
            agree = max(0.0, float(np.cos(2 * delta)))
        score = _gauss(residual, config.wall_sigma) * agree * lateral
        if score > best:
            best, best_id = score, wall.id
    return best, best_id


def object_support(child: InstanceGeometry, parent: InstanceGeometry, config: SceneGraphConfig) -> float:
    """G for (child, rests-on, parent): an upward face of the parent at the child's bottom, under it."""
    if child.empty or parent.empty or not parent.bottom < child.bottom - config.support_tol:
        return 0.0
    band = max(config.support_tol, CONTACT_BAND_RATIO * (child.top - child.bottom))
    footprint = child.points[child.height <= child.bottom + band][:, :2]
    face_mask = parent.upward & (np.abs(parent.height - child.bottom) <= 2 * config.support_tol)
    if len(footprint) == 0 or face_mask.sum() < 3:
        return 0.0
    face = parent.points[face_mask]
    dist, idx = cKDTree(face[:, :2]).query(footprint, distance_upper_bound=config.support_radius)
    hit = np.isfinite(dist)
    if not hit.any():
        return 0.0
    gap = abs(float(np.median(parent.height[face_mask][idx[hit]])) - child.bottom)
    return _gauss(gap, config.support_sigma) * float(hit.mean())


def geometric_prior(
    child: InstanceGeometry,
    parent: Parent,
    geometry: dict[InstanceId, InstanceGeometry],
    shell: RoomShell,
    config: SceneGraphConfig,
) -> float:
    """G_k for an edge into ``child`` from ``parent`` (the relation follows the parent type)."""
    if parent == Root.FLOOR:
        return floor_contact(child, config)
    if parent == Root.WALL:
        return wall_alignment(child, shell, config)[0]
    other = geometry.get(InstanceId(int(parent)))
    return 0.0 if other is None else object_support(child, other, config)


def shell_prior(child: InstanceGeometry, parent: Parent, shell: RoomShell, config: SceneGraphConfig) -> float:
    """The room-shell prior of an edge into ``child`` (see the module docstring)."""
    if child.empty:
        return 0.0
    touches = _gauss(max(0.0, child.bottom), config.floor_sigma)
    if parent == Root.FLOOR:
        return touches * child.inside
    if parent == Root.WALL:
        near = 0.0
        for wall in shell.walls:
            residual, lateral = wall_fit(child.points, wall)
            near = max(near, _gauss(residual, config.wall_sigma) * lateral)
        return (1.0 - touches) * near
    return (1.0 - touches) * child.inside
