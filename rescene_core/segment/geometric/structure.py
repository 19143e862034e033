"""The room's structure in the fused mesh: the floor, the ceiling and the walls as planes (their
ends trimmed where the room lies behind them), and distances of points to them."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.config import SegmentConfig


def _wall_span(along: NDArray, bin_size: float) -> tuple[float, float]:
    """The wall's own stretch along its plane (m): the run of ``bin_size`` bins holding the most of a plane's
    inliers ``along`` [k] (positions along the wall; a bin is occupied with 5 % of the fullest bin's
    count), with gaps up to 0.8 m bridged (a wardrobe hides the wall behind it). Furniture faces that happen
    to be coplanar with the wall elsewhere in the room fall outside."""
    if len(along) == 0:
        return 0.0, 0.0
    edges = np.arange(along.min(), along.max() + 2 * bin_size, bin_size)
    hist, edges = np.histogram(along, bins=edges)
    occupied = hist >= 0.05 * hist.max()
    best, best_pts, start, gap = (0, 0), -1, None, 0
    max_gap = int(round(0.8 / bin_size))
    for i, occ in enumerate(np.r_[occupied, np.zeros(max_gap + 1, bool)]):
        if occ:
            start = i if start is None else start
            gap = 0
            end = i
        elif start is not None:
            gap += 1
            if gap > max_gap:
                pts = int(hist[start : end + 1].sum())
                if pts > best_pts:
                    best, best_pts = (start, end), pts
                start, gap = None, 0
    return float(edges[best[0]]), float(edges[best[1] + 1])


def _trim_overhang(along: NDArray, side: NDArray, lo: float, hi: float, cfg: SegmentConfig) -> tuple[float, float]:
    """A wall's stretch [lo, hi] (m along it) less the ``wall_bin`` bins at either end in which more than
    ``wall_max_behind`` of the scene's points (at positions ``along`` [k], signed distances ``side`` [k] from
    the plane, positive towards the room) lie behind the plane: the inner walls of an L-shaped room, whose
    plane runs on past the corner across the other arm (coplanar faces of furniture there stretch the span
    over it). Nothing is left of a face with the room behind it all along, or behind some bin between the
    ends kept (a wardrobe's front standing in the room before the inner wall it hides)."""
    edges = np.arange(lo, hi + cfg.wall_bin, cfg.wall_bin)
    if len(edges) < 2:
        return lo, hi
    total, _ = np.histogram(along, bins=edges)
    behind, _ = np.histogram(along[side < -2 * cfg.plane_distance], bins=edges)
    ok = behind <= cfg.wall_max_behind * np.maximum(total, 1)
    clear = np.flatnonzero(ok)
    if len(clear) == 0:
        return lo, lo
    if (clear[0] > 0 or clear[-1] < len(ok) - 1) and not ok[clear[0] : clear[-1] + 1].all():
        # trimmed, and the room lies behind it between its ends as well: a furniture face standing in the
        # room in line with a wall hidden behind it (a wardrobe's front before an inner wall), not a wall
        return lo, lo
    return float(edges[clear[0]]), min(float(edges[clear[-1] + 1]), hi)


def _side_within(
    points: NDArray, normal: NDArray, offset: float, horiz: NDArray, lo: float, hi: float, cfg: SegmentConfig
) -> NDArray[np.float64]:
    """Signed distances (m, positive towards the room) from a wall plane (``normal`` [3], ``offset``) of the
    points [k, 3] lying along its stretch [lo, hi] (m along ``horiz`` [3]), kept two ``wall_bin`` inside its
    ends (the perpendicular wall at an inner corner stands right there)."""
    along = points @ horiz
    within = (along > lo + 2 * cfg.wall_bin) & (along < hi - 2 * cfg.wall_bin)
    return points[within] @ normal + offset


def _share_behind(side: NDArray, cfg: SegmentConfig) -> float:
    """Share of the signed distances ``side`` [k] (``_side_within``) behind the plane by more than two
    ``plane_distance``; 1 when there are none."""
    return float((side < -cfg.plane_distance * 2).mean()) if len(side) else 1.0


def _structure(
    verts: NDArray, normals: NDArray, cams: NDArray, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], list[dict[str, Any]]]:
    """Structure label per vertex (0 none, 1 floor, 2.. walls, then ceiling) and the planes found."""
    import open3d as o3d

    labels = np.zeros(len(verts), np.int64)
    labels[verts[:, 2] < cfg.floor_band] = 1
    planes: list[dict[str, Any]] = [{"kind": "floor", "id": 1, "vertices": int((labels == 1).sum())}]
    cos_n = np.cos(np.radians(cfg.plane_normal_deg))
    sin_v = np.sin(np.radians(cfg.vertical_tolerance_deg))
    top_cam = float(cams[:, 2].max()) if len(cams) else 0.0
    centre = cams.mean(axis=0) if len(cams) else verts.mean(axis=0)
    free = labels == 0
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[free]))
    pcd = pcd.voxel_down_sample(cfg.plane_voxel)
    thin = np.asarray(pcd.points)
    rest = pcd
    next_id = 2
    walls: list[tuple[NDArray, float, NDArray, float, float]] = []
    ceiling: float | None = None
    for _ in range(cfg.max_planes):
        if len(rest.points) < 200:
            break
        (a, b, c, d), inl = rest.segment_plane(cfg.plane_distance, 3, cfg.plane_iterations)
        n = np.array([a, b, c])
        n, d = n / np.linalg.norm(n), d / np.linalg.norm(n)
        pts = np.asarray(rest.points)[inl]
        rest = rest.select_by_index(inl, invert=True)
        if len(inl) < 200:
            break
        if n @ (centre - 0) + d < 0:  # orient towards the cameras (into the room)
            n, d = -n, -d
        if abs(n[2]) < sin_v:
            horiz = np.cross(n, [0.0, 0.0, 1.0])
            horiz /= np.linalg.norm(horiz)
            lo, hi = _wall_span(pts @ horiz, cfg.wall_bin)
            on_wall = (pts @ horiz >= lo) & (pts @ horiz <= hi)
            height = float(np.ptp(pts[on_wall, 2]))
            # only what lies behind the wall's own span counts: in an L-shaped room the other arm lies
            # behind the plane of an inner wall, beside the wall itself
            side = _side_within(thin, n, d, horiz, lo, hi, cfg)
            if (side < -cfg.plane_distance * 2).sum() > (side > cfg.plane_distance * 2).sum():
                # the room lies on the other side (the cameras' centre can lie outside an L-shaped room's arm)
                n, d, horiz, side = -n, -d, -horiz, -side
                lo, hi = -hi, -lo
            behind = _share_behind(side, cfg)
            if behind > cfg.wall_max_behind:
                # an inner wall whose plane runs on across the room's other arm: its stretch less the ends
                # with the room behind them
                lo, hi = _trim_overhang(thin @ horiz, thin @ n + d, lo, hi, cfg)
                behind = _share_behind(_side_within(thin, n, d, horiz, lo, hi, cfg), cfg)
            # a face parallel to a wall just in front of it is furniture against the wall (a wardrobe's front)
            # (measured at its own inliers: a plane tilted a degree off the wall it parallels crosses it)
            shadow = any(
                n @ w[0] > 0.98 and -cfg.plane_distance < np.median(pts[on_wall] @ w[0] + w[1]) < cfg.wall_shadow
                for w in walls
            )
            if (
                hi - lo >= cfg.wall_min_extent
                and height >= cfg.wall_min_extent
                and behind <= cfg.wall_max_behind
                and not shadow
            ):
                walls.append((n, d, horiz, lo, hi))
        elif abs(n[2]) > np.cos(np.radians(cfg.vertical_tolerance_deg)):
            z = float(np.median(pts[:, 2]))
            if z > top_cam + cfg.ceiling_min_above_cameras and (ceiling is None or z > ceiling):
                ceiling = z
    found_by = "plane"
    if ceiling is None:
        # left out, the strips of ceiling the cameras did see become object segments
        ceiling, found_by = _ceiling_slab(verts[free], normals[free], top_cam, cfg), "downward slab"
    for n, d, horiz, lo, hi in walls:
        along = verts @ horiz
        on = free & (np.abs(verts @ n + d) < cfg.plane_distance) & (np.abs(normals @ n) > cos_n)
        on &= (along >= lo - cfg.plane_distance) & (along <= hi + cfg.plane_distance)
        labels[on] = next_id
        planes.append({"kind": "wall", "id": next_id, "normal": n.round(4).tolist(), "offset": round(float(d), 4),
                       "span": [round(float(lo), 4), round(float(hi), 4)], "vertices": int(on.sum())})  # fmt: skip
        free &= ~on
        next_id += 1
    if ceiling is not None:
        z = ceiling
        on = free & (verts[:, 2] > z - cfg.plane_distance) & (np.abs(normals[:, 2]) > cos_n)
        on |= free & (verts[:, 2] > z + cfg.plane_distance)
        labels[on] = next_id
        planes.append(
            {"kind": "ceiling", "id": next_id, "height": round(z, 4), "vertices": int(on.sum()), "found_by": found_by}
        )
    return labels, planes


def _ceiling_slab(verts: NDArray, normals: NDArray, top_cam: float, cfg: SegmentConfig) -> float | None:
    """Height (m) of a ceiling too little seen for the plane search, from mesh vertices [v, 3] and their unit
    normals [v, 3] (world frame, z up) off the floor: the median height of the downward-facing vertices
    (within ``vertical_tolerance_deg`` of down) in the slab within ``plane_distance`` of a height that holds
    the most of them, above ``top_cam`` (the highest camera, m) by ``ceiling_min_above_cameras``. None when
    that slab holds fewer than ``ceiling_min_vertices`` or as many vertices lie above it."""
    band = cfg.plane_distance
    down = normals[:, 2] < -np.cos(np.radians(cfg.vertical_tolerance_deg))
    z = np.sort(verts[down & (verts[:, 2] > top_cam + cfg.ceiling_min_above_cameras), 2])
    if len(z) < cfg.ceiling_min_vertices:
        return None
    heights = np.arange(z[0], z[-1] + 0.01, 0.01)  # 1 cm steps
    counts = np.searchsorted(z, heights + band, "right") - np.searchsorted(z, heights - band, "left")
    best = int(np.argmax(counts))
    if counts[best] < cfg.ceiling_min_vertices:
        return None
    height = float(np.median(z[np.abs(z - heights[best]) <= band]))
    if int((verts[:, 2] > height + band).sum()) >= cfg.ceiling_min_vertices:
        return None  # something stands above it: the underside of a thing hanging in the room
    return height


def _ceiling_height(planes: list[dict[str, Any]]) -> float:
    """Height of the ceiling plane (m), infinite when none was found."""
    ceiling = [float(p["height"]) for p in planes if p["kind"] == "ceiling"]
    return ceiling[0] if ceiling else float(np.inf)


def _wall_coordinates(p: NDArray, plane: dict[str, Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Of points ``p`` [k, 3]: the signed distance [k] (m) in front of a wall plane (``normal``, ``offset``) and
    the position [k] (m) along it, in the coordinate of its ``span`` (along ``normal`` x up)."""
    normal = np.asarray(plane["normal"], float)
    horiz = np.cross(normal, [0.0, 0.0, 1.0])
    return p @ normal + plane["offset"], p @ (horiz / np.linalg.norm(horiz))


def _structure_distance(p: NDArray, planes: list[dict[str, Any]]) -> NDArray[np.float64]:
    """Distance [k] of points [k, 3] to the nearest structure plane: the floor (z = 0), a wall, the ceiling (m)."""
    dist = np.abs(p[:, 2])
    for plane in planes:
        if plane["kind"] == "wall":
            dist = np.minimum(dist, np.abs(p @ np.asarray(plane["normal"]) + plane["offset"]))
        elif plane["kind"] == "ceiling":
            dist = np.minimum(dist, np.abs(p[:, 2] - plane["height"]))
    return dist


def _mostly_structure(dist: NDArray, cfg: SegmentConfig) -> bool:
    """Whether ``structure_sliver_fraction`` of a region's points, ``dist`` [k] (m) from the nearest structure
    plane (``_structure_distance``), lie within ``structure_band`` of it: the first test of a sliver."""
    return bool((dist < cfg.structure_band).mean() >= cfg.structure_sliver_fraction)


def _is_wall_piece(p: NDArray, cfg: SegmentConfig) -> bool:
    """A region [k, 3] that is one upright sheet (under ``sliver_thickness`` thick across its flattest
    direction, which is horizontal) and at least ``wall_piece_height`` tall: a stretch of wall the plane
    search missed, or a door; no piece of furniture is a sheet that tall."""
    if np.ptp(p[:, 2]) < cfg.wall_piece_height or len(p) < 10:
        return False
    centred = p - p.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    if abs(normal[2]) > np.sin(np.radians(cfg.vertical_tolerance_deg)):
        return False
    across = centred @ normal
    return bool(np.subtract(*np.percentile(across, [95, 5])) < cfg.sliver_thickness)


def _nearest_wall(p: NDArray, planes: list[dict[str, Any]]) -> int:
    """Id of the wall nearest (by median distance) to the points [k, 3]; 0 when there is no wall."""
    walls = [q for q in planes if q["kind"] == "wall"]
    if not walls:
        return 0
    gaps = [float(np.median(np.abs(p @ np.asarray(q["normal"]) + q["offset"]))) for q in walls]
    return int(walls[int(np.argmin(gaps))]["id"])


def _out_from_wall(p: NDArray, planes: list[dict[str, Any]]) -> float:
    """How far the points [k, 3] reach out from their nearest wall (``_nearest_wall``): the extent (m) of their
    distances to its plane; 0 when there is no wall."""
    wall = _nearest_wall(p, planes)
    if wall == 0 or len(p) == 0:
        return 0.0
    q = next(q for q in planes if q["id"] == wall)
    return float(np.ptp(p @ np.asarray(q["normal"])))


def _faces_wall(p: NDArray, normals: NDArray, planes: list[dict[str, Any]], cfg: SegmentConfig) -> bool:
    """Whether most points [k, 3] of a region lie with their normals [k, 3] within ``plane_normal_deg`` of
    the normal of the wall nearest to them (by median distance)."""
    wall = _nearest_wall(p, planes)
    if wall == 0:
        return False
    n = np.asarray(next(q["normal"] for q in planes if q["kind"] == "wall" and q["id"] == wall))
    return bool((np.abs(normals @ n) > np.cos(np.radians(cfg.plane_normal_deg))).mean() >= 0.5)
