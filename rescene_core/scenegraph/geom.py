"""Small geometric measurements shared by the geometric backend and the fusion priors.

All points are world-frame metres, float64 [n, 3]; heights are signed distances above the floor plane.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rescene_core.capture import Capture
from rescene_core.records import Plane, RoomShell, WallPlane

EXTREME_POINTS = 8
"""The lower contact surface is the height of the k-th lowest point, k = max(this, EXTREME_FRACTION x n):
a count, not a quantile, because the points near a contact are few (the contact itself is hidden)."""
EXTREME_FRACTION = 0.002
WALL_LATERAL_MARGIN = 0.10
"""Points within this distance beyond a wall segment's ends still count as in front of it (m)."""
SPAN_QUANTILE = 0.10
"""The bulk of an instance's points (this quantile to 1 - it) measures how far it spans off a wall: mask
edges bleed onto the wall behind and onto far surfaces, so the extremes are not used."""


def floor_only_shell(capture: Capture) -> RoomShell:
    """A stand-in shell when none is given: a horizontal floor at the 1st percentile of all point
    heights, the convex hull of all points as the floor polygon, and no walls."""
    from shapely.geometry import MultiPoint

    pts, _ = capture.all_points()
    if not len(pts):
        raise ValueError(f"{capture.path}: no points to place a floor; give a room shell")
    z0 = float(np.quantile(pts[:, 2], 0.01))
    hull = MultiPoint(np.asarray(pts[:, :2], np.float64)).convex_hull
    coords = list(hull.exterior.coords)[:-1] if hull.geom_type == "Polygon" else []
    return RoomShell(Plane((0.0, 0.0, 1.0), -z0), (), tuple((float(x), float(y)) for x, y in coords))


def lower_surface(height: NDArray) -> float:
    """Height (m) of an instance's lower contact surface from its point heights [n] (inf when empty)."""
    n = len(height)
    if n == 0:
        return float("inf")
    k = min(n - 1, max(EXTREME_POINTS, int(EXTREME_FRACTION * n)) - 1)
    return float(np.partition(height, k)[k])


def upper_surface(height: NDArray) -> float:
    """Height (m) of an instance's top from its point heights [n] (-inf when empty)."""
    return -lower_surface(-np.asarray(height)) if len(height) else float("-inf")


def upward_mask(points: NDArray, shell: RoomShell, neighbours: int, max_angle_deg: float) -> NDArray[np.bool_]:
    """bool [n]: points whose normal (Open3D, k nearest neighbours) is within ``max_angle_deg`` of the floor
    normal, i.e. points on upward- (or downward-) facing surfaces."""
    import open3d as o3d

    pts = np.asarray(points, dtype=np.float64)
    if len(pts) < 3:
        return np.zeros(len(pts), bool)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=min(neighbours, len(pts))))
    up = np.asarray(shell.floor.normal, dtype=np.float64)
    return np.abs(np.asarray(cloud.normals) @ up) >= np.cos(np.deg2rad(max_angle_deg))


def heights(shell: RoomShell, points: NDArray) -> NDArray[np.float64]:
    """Height of each point above the floor plane (m), [n]."""
    return shell.floor.signed_distance(points)


def wall_fit(points: NDArray, wall: WallPlane) -> tuple[float, float]:
    """(back-surface distance to the wall's plane in m, fraction of points laterally in front of the wall).

    The back surface is found like the lower contact surface, along the wall normal (negative when behind).
    """
    if not len(points):
        return float("inf"), 0.0
    d = wall.plane.signed_distance(points)
    residual = lower_surface(d)
    (x0, y0), (x1, y1) = wall.segment
    seg = np.array([x1 - x0, y1 - y0], np.float64)
    length = float(np.linalg.norm(seg))
    if length < 1e-9:
        return abs(residual), 0.0
    s = (np.asarray(points)[:, :2] - [x0, y0]) @ (seg / length)
    lateral = float(np.mean((s >= -WALL_LATERAL_MARGIN) & (s <= length + WALL_LATERAL_MARGIN)))
    return abs(residual), lateral


def wall_back(points: NDArray, wall: WallPlane) -> float:
    """Robust distance (m) of an instance's back surface to a wall plane, from the points' signed distances
    d (positive in front): max(0, the SPAN_QUANTILE quantile of d) + max(0, -median of d); inf when empty.

    Unlike ``wall_fit``'s count-based extreme, the quantile ignores the few stray points an instance's
    cloud carries (mask edges bled onto the wall, mixed depth at silhouettes, mislabelled pixels far away),
    which can sit right at a wrong wall or behind the right one; it includes part of the object's thickness
    (a few cm for things hung on a wall). It is one-sided: a thing hung flat on a wall shows its surface a
    centimetre or two in front of the plane, and depth noise (and the plane's own fit) spreads those points
    to both sides of it (on the cluttered scenes 10% of a mirror's points lie 3-6 cm behind its wall), so
    points behind the plane mean the back reaches the wall, not that it is that far from it. Only a bulk
    (median) behind the plane is a distance: the thing is behind that wall, not on it."""
    if not len(points):
        return float("inf")
    lo, mid = np.quantile(wall.plane.signed_distance(points), [SPAN_QUANTILE, 0.5])
    return float(max(0.0, lo) + max(0.0, -mid))


def wall_flush(points: NDArray, shell: RoomShell, min_lateral: float = 0.5) -> tuple[WallPlane | None, float, float]:
    """The wall the points lie flat against: among the walls they stand in front of, the one whose plane is
    nearest to their bulk. Returns (wall, |median signed distance| of the points to its plane in m, their
    spread along its normal in m: the SPAN_QUANTILE to 1 - SPAN_QUANTILE range); (None, inf, inf) when
    they stand in front of no wall.

    Unlike ``wall_fit``'s back surface, the median measures where the object's bulk is: a picture's or a
    mirror's points lie within its thickness of the wall, a monitor's or a lamp's stand well in front of it
    even when their backs touch the wall.
    """
    best, best_d, best_span = None, float("inf"), float("inf")
    pts = np.asarray(points, dtype=np.float64)
    if not len(pts):
        return best, best_d, best_span
    for wall in shell.walls:
        if wall_fit(pts, wall)[1] < min_lateral:
            continue
        d = wall.plane.signed_distance(pts)
        lo, mid, hi = np.quantile(d, [SPAN_QUANTILE, 0.5, 1.0 - SPAN_QUANTILE])
        if abs(mid) < best_d:
            best, best_d, best_span = wall, float(abs(mid)), float(hi - lo)
    return best, best_d, best_span


def nearest_wall(points: NDArray, shell: RoomShell, min_lateral: float = 0.5) -> tuple[WallPlane | None, float]:
    """The wall whose plane is closest to the points' back surface, among walls they stand in front of."""
    best, best_d = None, float("inf")
    for wall in shell.walls:
        d, lateral = wall_fit(points, wall)
        if lateral >= min_lateral and d < best_d:
            best, best_d = wall, d
    return best, best_d
