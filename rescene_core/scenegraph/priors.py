"""Geometric prior G_k and room-shell prior of candidate edges, from instance point clouds P_i.

Fusion runs before and independently of registration, so these use the capture's point clouds, not
meshes. Every score is in [0, 1].

- floor parent: floor contact = exp(-(gap / floor_sigma)^2) x fraction of the footprint inside the floor
  polygon, gap = |height of the lower contact surface above the floor plane|;
- wall parent: wall alignment = max over walls of exp(-(residual / wall_sigma)^2) x normal agreement x
  lateral fraction, residual = robust distance of the back surface to the wall plane (``geom.wall_back``:
  the 10% quantile of the points' distances, so stray points do not decide it, one-sided, so depth noise
  that spreads a flush picture's points behind the plane is not a gap), normal agreement = how
  well the footprint's minimum-area rectangle lines up with the wall: (1 - e) |cos 2 phi| + e max(0,
  -cos 2 phi), phi the angle between the rectangle's long side and the wall normal, e = 1 - short / long
  side its elongation. A near-square footprint may face any of its four sides to the wall (the first
  term, modulo 90 deg); an elongated one hangs with its long side along the wall and its thin axis along
  the wall normal (the second term, modulo 180 deg), which tells apart the two walls of a corner that a
  picture or a shelf touches (its side edge lies against the perpendicular wall as closely as its back
  against its own). The argmax wall is the edge's wall_id;
- object parent: support = exp(-(gap / support_sigma)^2) x the fraction of the child's contact footprint
  above an upward-facing face of the parent from ``support_gap`` below to 2 ``support_tol`` above the
  child's bottom, the parent judged by its top surface around the child, not its lowest visible point
  (``geom.holds_from_below``: an island seen only from above holds the cup on it).

A large horizontal top at counter height with nothing seen below (``top_only``, ``geom.seen_only_from_above``)
touches the floor (floor contact 1, here and in the shell prior): its base is out of view, not absent.

Room-shell prior: floor = touches x inside; wall = (1 - touches) x near a wall (the best wall's
exp(-(residual / wall_sigma)^2) x lateral fraction, with the same back distance); object = (1 - touches)
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
from rescene_core.scenegraph.geom import (
    heights,
    holds_from_below,
    lower_surface,
    near_footprint,
    seen_only_from_above,
    upper_surface,
    upward_mask,
    wall_back,
    wall_fit,
)

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
    yaw: direction of the long side of the footprint's minimum-area rectangle (rad, world xy), or None
    when degenerate. elongation: 1 - short side / long side of that rectangle, in [0, 1] (0 = square).
    top_only: a large horizontal top at counter height with nothing seen below it (``geom.seen_only_from_above``):
    a counter, an island or a table whose base was out of view, taken to stand on the floor.
    """

    instance: InstanceId
    points: NDArray[np.float64]
    height: NDArray[np.float64]
    upward: NDArray[np.bool_]
    bottom: float
    top: float
    inside: float
    yaw: float | None
    elongation: float = 0.0
    top_only: bool = False

    @property
    def empty(self) -> bool:
        return len(self.points) == 0


def footprint_axes(xy: NDArray) -> tuple[float | None, float]:
    """(yaw of the long side in rad, elongation = 1 - short / long side) of the minimum-area rectangle of
    the points ``xy`` [n, 2] (shapely); (None, 0) when the rectangle is degenerate."""
    rect = MultiPoint(xy).minimum_rotated_rectangle
    if rect.geom_type != "Polygon":
        return None, 0.0
    c = np.asarray(rect.exterior.coords)
    e1, e2 = c[1] - c[0], c[2] - c[1]
    l1, l2 = float(np.linalg.norm(e1)), float(np.linalg.norm(e2))
    if max(l1, l2) < 1e-9:
        return None, 0.0
    long_side = e1 if l1 >= l2 else e2
    return float(np.arctan2(long_side[1], long_side[0])), 1.0 - min(l1, l2) / max(l1, l2)


def normal_agreement(child: InstanceGeometry, wall_normal: NDArray) -> float:
    """How well the child's footprint lines up with a wall of horizontal normal ``wall_normal`` (see the
    module docstring), in [0, 1]; 1 when the footprint is degenerate (no orientation to compare)."""
    if child.yaw is None:
        return 1.0
    phi = float(np.arctan2(wall_normal[1], wall_normal[0])) - child.yaw
    c2 = float(np.cos(2 * phi))  # +1: long side along the normal, -1: long side along the wall
    e = float(np.clip(child.elongation, 0.0, 1.0))
    return (1.0 - e) * abs(c2) + e * max(0.0, -c2)


def drop_strays(points: NDArray, config: SceneGraphConfig) -> NDArray[np.float64]:
    """The points [n, 3] (world m) less those DBSCAN (Open3D, radius ``outlier_eps``, ``outlier_min_points``
    neighbours) leaves as noise. An instance's cloud gathers, over many frames, stray points from mask edges
    and mixed depth at silhouettes; they lie scattered across the room (on cluttered scenes up to a few
    percent of the points, metres away), below the object's bottom and beside its footprint, where they set
    the lower contact surface and the footprint rectangle. The points are returned unchanged when the
    filter is off, when there are too few of them, or when it would leave fewer than half of them."""
    pts = np.asarray(points, dtype=np.float64)
    if config.fusion.outlier_min_points <= 0 or len(pts) < 2 * config.fusion.outlier_min_points:
        return pts
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    labels = np.asarray(
        cloud.cluster_dbscan(eps=config.fusion.outlier_eps, min_points=config.fusion.outlier_min_points)
    )
    keep = labels >= 0
    return pts[keep] if keep.sum() >= 0.5 * len(pts) else pts


def instance_geometry(
    capture: Capture, instance: int, shell: RoomShell, config: SceneGraphConfig, seed: int = 0
) -> InstanceGeometry:
    """Measure P_i of one instance against the shell (at most ``max_fusion_points`` points, strays dropped
    by ``drop_strays``)."""
    pts = np.asarray(capture.point_cloud(instance).points, dtype=np.float64)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) > config.fusion.max_fusion_points:
        pts = pts[
            np.random.default_rng(seed + int(instance)).choice(len(pts), config.fusion.max_fusion_points, replace=False)
        ]
    pts = drop_strays(pts, config)
    iid = InstanceId(int(instance))
    if len(pts) < 3:
        return InstanceGeometry(
            iid, pts.reshape(-1, 3), np.zeros(len(pts)), np.zeros(len(pts), bool), np.inf, -np.inf, 0.0, None
        )
    h = heights(shell, pts)
    upward = upward_mask(pts, shell, config.geometric.normal_neighbours, config.geometric.upward_normal_deg)
    polygon = shell.polygon().buffer(POLYGON_TOLERANCE) if len(shell.floor_polygon) >= 3 else None
    inside = float(shapely.contains_xy(polygon, pts[:, 0], pts[:, 1]).mean()) if polygon is not None else 1.0
    yaw, elongation = footprint_axes(pts[:, :2])
    return InstanceGeometry(
        iid,
        pts,
        h,
        upward,
        lower_surface(h),
        upper_surface(h),
        inside,
        yaw,
        elongation,
        seen_only_from_above(h, pts[:, :2]),
    )


def _gauss(x: float, sigma: float) -> float:
    return float(np.exp(-((x / sigma) ** 2))) if np.isfinite(x) else 0.0


def _floor_touch(child: InstanceGeometry, config: SceneGraphConfig) -> float:
    """exp(-(gap / floor_sigma)^2) of the child's bottom above the floor; 1 for a top seen only from above,
    whose base is out of view, not absent."""
    return 1.0 if child.top_only else _gauss(abs(child.bottom), config.fusion.floor_sigma)


def floor_contact(child: InstanceGeometry, config: SceneGraphConfig) -> float:
    """G for (child, rests-on, floor)."""
    if child.empty:
        return 0.0
    return _floor_touch(child, config) * child.inside


def wall_alignment(child: InstanceGeometry, shell: RoomShell, config: SceneGraphConfig) -> tuple[float, int | None]:
    """G for (child, mounts-on, wall): best over walls, and that wall's id (the edge's wall_id)."""
    best, best_id = 0.0, None
    if child.empty:
        return best, best_id
    for wall in shell.walls:
        lateral = wall_fit(child.points, wall)[1]
        residual = wall_back(child.points, wall)
        agree = normal_agreement(child, np.asarray(wall.plane.normal, dtype=np.float64))
        score = _gauss(residual, config.fusion.wall_sigma) * agree * lateral
        if score > best:
            best, best_id = score, wall.id
    return best, best_id


def object_support(child: InstanceGeometry, parent: InstanceGeometry, config: SceneGraphConfig) -> float:
    """G for (child, rests-on, parent): an upward face of the parent at the child's bottom, under it, at most
    ``support_gap`` below it; the parent judged by its top surface around the child (``geom.holds_from_below``),
    not by its lowest visible point."""
    if child.empty or parent.empty:
        return 0.0
    cfg = config.geometric
    band = max(cfg.support_tol, CONTACT_BAND_RATIO * (child.top - child.bottom))
    footprint = child.points[child.height <= child.bottom + band][:, :2]
    around = near_footprint(parent.points, footprint, cfg.support_radius)
    if len(footprint) == 0 or not holds_from_below(
        parent.points, parent.height, parent.bottom, around, footprint, child.bottom, cfg.support_tol
    ):
        return 0.0
    face_mask = (
        parent.upward
        & (parent.height >= child.bottom - cfg.support_gap)
        & (parent.height <= child.bottom + 2 * cfg.support_tol)
    )
    if face_mask.sum() < 3:
        return 0.0
    face = parent.points[face_mask]
    dist, idx = cKDTree(face[:, :2]).query(footprint, distance_upper_bound=config.geometric.support_radius)
    hit = np.isfinite(dist)
    if not hit.any():
        return 0.0
    gap = abs(float(np.median(parent.height[face_mask][idx[hit]])) - child.bottom)
    return _gauss(gap, config.fusion.support_sigma) * float(hit.mean())


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
    touches = 1.0 if child.top_only else _gauss(max(0.0, child.bottom), config.fusion.floor_sigma)
    if parent == Root.FLOOR:
        return touches * child.inside
    if parent == Root.WALL:
        near = 0.0
        for wall in shell.walls:
            lateral = wall_fit(child.points, wall)[1]
            near = max(near, _gauss(wall_back(child.points, wall), config.fusion.wall_sigma) * lateral)
        return (1.0 - touches) * near
    return (1.0 - touches) * child.inside
