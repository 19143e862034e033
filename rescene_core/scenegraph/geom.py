"""Small geometric measurements shared by the geometric backend and the fusion priors.

All points are world-frame metres, float64 [n, 3]; heights are signed distances above the floor plane.
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from shapely.geometry import MultiPoint

from rescene_core.capture import Capture
from rescene_core.records import Plane, RoomShell, WallPlane

EXTREME_POINTS = 8
"""The lower contact surface is the height of the k-th lowest point, k = max(this, EXTREME_FRACTION x n):
a count, not a quantile, because the points near a contact are few (the contact itself is hidden)."""
EXTREME_FRACTION = 0.002
WALL_LATERAL_MARGIN = 0.10
"""Points within this distance beyond a wall segment's ends still count as in front of it (m)."""
COUNTER_HEIGHTS = (0.6, 1.2)
"""A large horizontal top between these heights (m) with nothing seen below it is a counter, an island or a
table (``seen_only_from_above``): a head-mounted camera looking down at it never sees its base."""
COUNTER_MIN_SPAN = 0.30
"""... large: the bulk of its points (the SPAN_QUANTILE to 1 - SPAN_QUANTILE range) spans at least this
along both horizontal principal axes (m), so a top about 0.4 m or more on each side; a wall shelf (about
0.3 m deep), a tray, a cutting board or a stack of books is smaller. The bulk, not the extremes: a cloud's
stray points stretch a book stack's minimum-area rectangle to 0.5 m."""
COUNTER_DEPTH = 0.10
"""... nothing seen below: at least COUNTER_TOP_SHARE of its points lie within this of its top (m)."""
COUNTER_TOP_SHARE = 0.90
"""See COUNTER_DEPTH: the share of an instance's points on its top for it to be seen only from above."""
SPAN_QUANTILE = 0.10
"""The bulk of an instance's points (this quantile to 1 - it) measures how far it spans off a wall: mask
edges bleed onto the wall behind and onto far surfaces, so the extremes are not used."""


def floor_only_shell(capture: Capture) -> RoomShell:
    """A stand-in shell when none is given: a horizontal floor at the 1st percentile of all point
    heights, the convex hull of all points as the floor polygon, and no walls."""

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


def near_footprint(points: NDArray, footprint_xy: NDArray, radius: float) -> NDArray[np.bool_]:
    """bool [n]: the points [n, 3] whose horizontal position is within ``radius`` (m) of some point of
    ``footprint_xy`` [m, 2] (under or beside that footprint)."""
    pts = np.asarray(points, dtype=np.float64)
    if not len(pts) or not len(footprint_xy):
        return np.zeros(len(pts), bool)
    dist = cKDTree(np.asarray(footprint_xy, dtype=np.float64)).query(pts[:, :2], distance_upper_bound=radius)[0]
    return np.isfinite(dist)


def holds_from_below(
    parent_points: NDArray,
    parent_height: NDArray,
    parent_bottom: float,
    around: NDArray[np.bool_],
    child_xy: NDArray,
    child_bottom: float,
    tol: float,
) -> bool:
    """Whether an instance can hold a child from below, judged by its top surface, not its lowest point.

    parent_points: [n, 3] its points, parent_height: [n] their heights (m); parent_bottom: its lower contact
    surface (m); around: bool [n], its points under or beside the child's footprint (``near_footprint``);
    child_xy: [m, 2] the child's points' horizontal positions; child_bottom: the child's lower contact
    surface (m); tol: ``support_tol``. True when the instance reaches further down than the child's bottom
    (furniture seen down to its base, or a shelf unit: the child may stand on any shelf of it), or when its
    points around the child rise no higher than ``tol`` above the child's bottom, in bulk (the 1 - SPAN_QUANTILE
    quantile: the child's own outline bleeds into the parent's mask, on the synthetic egocentric scenes 1%
    of a tray's points around a jar on it reach the jar's top) and the child's centre (median position) is
    over it (inside the convex hull of its points): its top is where the child stands, a tray, or a
    counter or an island seen only from above, whose lowest visible point is its top. A neighbour standing
    on the same surface starts at the child's bottom and either rises above it or lies beside the child's
    centre, not under it (a tray beside a cup; the island does not rest on the tray on it). Whether it has an
    upward face at the child's bottom within ``support_gap`` is tested separately."""

    if parent_bottom < child_bottom - tol:
        return True
    if not around.any() or not len(child_xy):
        return False
    if np.quantile(np.asarray(parent_height)[around], 1.0 - SPAN_QUANTILE) > child_bottom + tol:
        return False
    hull = MultiPoint(np.asarray(parent_points, dtype=np.float64)[:, :2]).convex_hull
    centre = np.median(np.asarray(child_xy, dtype=np.float64), axis=0)
    return bool(shapely.contains_xy(hull, centre[0], centre[1]))


def seen_only_from_above(height: NDArray, xy: NDArray) -> bool:
    """Whether an instance is a large horizontal top at counter height with nothing seen below it: its top
    (``upper_surface`` of ``height`` [n], m above the floor) between COUNTER_HEIGHTS, at least
    COUNTER_TOP_SHARE of its points within COUNTER_DEPTH of that top, and the bulk of its horizontal
    positions ``xy`` [n, 2] at least COUNTER_MIN_SPAN across both principal axes (so a horizontal slab).
    Such a thing is a counter, an island or a table whose sides and base were out of view: it stands on the
    floor even though its lowest visible point is 0.6-1.2 m above it."""
    h = np.asarray(height, dtype=np.float64)
    if len(h) < 3:
        return False
    top = upper_surface(h)
    if not COUNTER_HEIGHTS[0] <= top <= COUNTER_HEIGHTS[1]:
        return False
    if (h >= top - COUNTER_DEPTH).mean() < COUNTER_TOP_SHARE:
        return False
    flat = np.asarray(xy, dtype=np.float64)
    flat = flat - flat.mean(axis=0)
    axes = np.linalg.eigh(np.cov(flat.T))[1]
    lo, hi = np.quantile(flat @ axes, [SPAN_QUANTILE, 1.0 - SPAN_QUANTILE], axis=0)
    return bool(np.all(hi - lo >= COUNTER_MIN_SPAN))


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
