"""Regions and the walls: superpoints of a wall's plane and paint, flush objects on it, regions hanging
on it, and what a region dropped as a stretch of wall or reaching out of its wall gives back."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.colour import _of_paint
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import (
    ScanPoints,
    _point_parts,
    _region_bounds,
    _regrouped,
    _touching_regions,
    points_by_region,
)
from rescene_core.segment.geometric.structure import (
    _ceiling_height,
    _mostly_structure,
    _out_from_wall,
    _structure_distance,
    _wall_coordinates,
)


def wall_superpoints(
    sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Per superpoint: the wall it lies on (0: none; the wall of most of its points) and whether it is a
    flush object on that wall (its colour differs from the wall's, or it stands proud of the plane)."""
    g = sp.graph
    n = g.size
    on = np.bincount(g.label, (sp.wall > 0).astype(float), n) / np.maximum(g.count, 1)
    which = np.zeros(n, np.int64)
    if (sp.wall > 0).any():
        key = g.label[sp.wall > 0] * (int(sp.wall.max()) + 1) + sp.wall[sp.wall > 0]
        uk, cnt = np.unique(key, return_counts=True)
        order = np.lexsort((-cnt, uk // (int(sp.wall.max()) + 1)))
        first_sp = uk[order] // (int(sp.wall.max()) + 1)
        first = np.r_[True, first_sp[1:] != first_sp[:-1]] if len(first_sp) else np.zeros(0, bool)
        which[first_sp[first]] = uk[order][first] % (int(sp.wall.max()) + 1)
    which[on < 0.5] = 0
    flush = np.zeros(n, bool)
    extent = (g.hi - g.lo).max(axis=1)
    # a superpoint that reaches down to the floor or up to the ceiling is no part of a flush object (a door
    # beside a mirror, of the wood of its frame, would otherwise take the mirror into the wall)
    hangs = (g.lo[:, 2] >= cfg.flush_min_height) & (g.hi[:, 2] <= _ceiling_height(planes) - cfg.flush_ceiling_gap)
    paint = wall_colours(sp)
    for plane in planes:
        if plane["kind"] != "wall":
            continue
        mine = sp.wall == plane["id"]
        if not mine.any():
            continue
        wall_colour = paint[int(plane["id"])]
        proud = np.bincount(g.label[mine], sp.points[mine] @ np.asarray(plane["normal"]) + plane["offset"], n)
        proud = proud / np.maximum(np.bincount(g.label[mine], minlength=n), 1)
        cand = (which == plane["id"]) & (~_of_paint(g.colour, wall_colour, cfg) | (proud >= cfg.flush_offset))
        flush |= cand & hangs & (extent <= cfg.flush_max_extent)
    # a hanging superpoint off every plane but lying wholly within ``structure_band`` in front of a wall,
    # along its stretch, is a piece of something hung on it (a clock's rim and face stand 2-4 cm proud,
    # beyond the plane's reach): a flush candidate on that wall, so its pieces join as one
    near = _near_wall(sp, planes, cfg)
    off = (which == 0) & (near > 0) & hangs & (extent <= cfg.flush_max_extent)
    which[off] = near[off]
    flush |= off
    return which, flush


def wall_colours(sp: ScanPoints) -> dict[int, NDArray[np.float64]]:
    """The colour [3] (RGB in [0, 1]) of each wall (by id) that scan points lie on: their median colour."""
    return {int(w): np.median(sp.colours[sp.wall == w], axis=0) for w in np.unique(sp.wall[sp.wall > 0])}


def _near_wall(sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig) -> NDArray[np.int64]:
    """Per superpoint [s]: the wall (id) all of whose points lie within ``structure_band`` in front of its
    plane and along its stretch, 0 when none."""
    g = sp.graph
    n = g.size
    near = np.zeros(n, np.int64)
    for plane in planes:
        if plane["kind"] != "wall":
            continue
        dist, along = _wall_coordinates(sp.points, plane)
        lo, hi = plane["span"]
        inside = (dist > -cfg.plane_distance) & (dist < cfg.structure_band) & (along >= lo) & (along <= hi)
        outside_count = np.bincount(g.label, (~inside).astype(float), n)
        near[(outside_count == 0) & (near == 0)] = int(plane["id"])
    return near


def part_from_wall_stretch(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """What stands against a stretch of wall its plane did not claim, parted from it. The stretch (a region at
    least ``wall_piece_height`` tall with ``structure_sliver_fraction`` of its points within
    ``structure_band`` of the structure planes) would be dropped whole as a sliver of the wall, and with it
    the desk joined to it; each connected part of its points at least ``stands_out`` off every plane,
    with ``min_segment_points`` points and ``min_segment_extent`` long, becomes a region of its own. The
    part's points nearer the wall stay with the stretch. ``region`` [s] (0: none), ``which`` [s]: the wall
    of each superpoint (0: none). Returns the scan points with the new superpoint graph, the region and
    wall of each new superpoint, and how many parts were parted."""
    point_region = region[sp.graph.label].copy()
    n = int(region.max(initial=0)) + 1
    order, bounds = points_by_region(point_region, n)
    nxt, parted = n, 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < cfg.min_segment_points or np.ptp(sp.points[idx, 2]) < cfg.wall_piece_height:
            continue
        dist = _structure_distance(sp.points[idx], planes)
        if not _mostly_structure(dist, cfg):
            continue
        off = np.zeros(len(sp.points), bool)
        off[idx[dist >= cfg.stands_out]] = True
        if off.sum() < cfg.min_segment_points:
            continue
        _, part = _point_parts(sp.edges, off)
        ids, counts = np.unique(part[off], return_counts=True)
        for c in ids[counts >= cfg.min_segment_points].tolist():
            mine = part == c
            if float(np.ptp(sp.points[mine], axis=0).max()) >= cfg.min_segment_extent:
                point_region[mine] = nxt
                nxt += 1
                parted += 1
    return _regrouped(sp, region, which, point_region, parted)


def take_off_wall_paint(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """An object's region with the points of the wall's paint taken off. A superpoint holding both wall and
    free points (the wall in a wall shelf's shadow fused with the shelf's brackets) is the wall's only when
    most of its points are, so an object's region takes in wall points with it. In a region under half on
    walls (no flush object), the points on a wall's plane (``ScanPoints.wall``) of its colour (a step under
    ``flush_colour_step``) or of its colour darkened (a shadow) are taken off (``_of_paint``, as
    ``wall_superpoints`` judges a superpoint). ``region`` [s] (0: none), ``which`` [s]: the wall of each
    superpoint (0: none). Returns the scan points with the new superpoint graph, the region and wall of
    each new superpoint, and how many points were taken off."""
    point_region = region[sp.graph.label].copy()
    n = int(region.max(initial=0)) + 1
    paint = wall_colours(sp)
    order, bounds = points_by_region(point_region, n)
    taken = 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        on = idx[sp.wall[idx] > 0]
        if len(on) == 0 or 2 * len(on) >= len(idx):
            continue
        if _out_from_wall(sp.points[idx], planes) < cfg.stands_out:
            continue  # hung flat on the wall (a clock, its face of the wall's white): the flush tests judge it
        if _mostly_structure(_structure_distance(sp.points[idx], planes), cfg):
            continue  # a sliver of the structure, dropped whole; without its paint it would no longer look one
        for w in np.unique(sp.wall[on]).tolist():
            mine = on[sp.wall[on] == w]
            plain = mine[_of_paint(sp.colours[mine], paint[w], cfg)]
            point_region[plain] = 0
            taken += len(plain)
    return _regrouped(sp, region, which, point_region, taken)


def _hangs(
    sp: ScanPoints,
    point_region: NDArray[np.int64],
    r: int,
    lo: NDArray,
    hi: NDArray,
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> bool:
    """Whether region r (bounds ``lo``, ``hi`` [3], m) hangs on a wall: clear of the floor (its lowest point
    above ``support_min_height``), fixed to a wall (``min_contacts`` of its points within ``structure_band``
    of a wall plane, most of them off it) and with nothing of another region under it (fewer than
    ``min_contacts`` points within its footprint from 2 ``support_band`` under its lowest point up to it). A
    wall shelf's bracket under the shelf's board hangs from it; a book stack under another stands on its
    shelf, and a lamp's shade stands on its stem."""
    mine = point_region == r
    if lo[2] <= cfg.support_min_height or (sp.wall[mine] > 0).mean() >= 0.5:
        return False
    walls = [q for q in planes if q["kind"] == "wall"]
    own = sp.points[mine]
    near = [np.abs(own @ np.asarray(q["normal"]) + q["offset"]) < cfg.structure_band for q in walls]
    if not walls or int(np.any(near, axis=0).sum()) < cfg.min_contacts:
        return False
    p = sp.points
    under = np.all((p[:, :2] >= lo[:2]) & (p[:, :2] <= hi[:2]), axis=1)
    under &= (p[:, 2] >= lo[2] - 2 * cfg.support_band) & (p[:, 2] < lo[2]) & (point_region > 0) & ~mine
    return int(under.sum()) < cfg.min_contacts


def _join_brackets(
    sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig, planes: list[dict[str, Any]]
) -> tuple[NDArray[np.int64], int]:
    """A slender region hanging on a wall (``_hangs``) and reaching ``bracket_min_depth`` out from it joins
    the broader region it touches whose points lie over its footprint (within ``stem_margin``) from
    ``support_band`` under its top to ``stem_gap`` over it, ``min_contacts`` of them: a wall shelf's bracket
    under the board. ``_join_stems`` misses it when the board's region already holds the other bracket,
    whose foot is then the region's lowest point. Slender: at most ``leg_width`` one way and clear of
    ``support_min_height``; broader: wider than it both ways. ``region`` [s] (0: none); returns the regions
    and how many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    width = hi[:, :2] - lo[:, :2]
    slender = (np.min(width, axis=1) <= cfg.leg_width) & (lo[:, 2] > cfg.support_min_height)
    slender[0] = False
    point_region = region[g.label]
    xy, z = sp.points[:, :2], sp.points[:, 2]
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, slender):
        for low, top in ((a, b), (b, a)):
            if not slender[low] or remap[low] != low or remap[top] != top or np.any(width[top] <= width[low]):
                continue
            centre = 0.5 * (lo[low, :2] + hi[low, :2])
            over = np.all(np.abs(xy - centre) <= 0.5 * width[low] + cfg.stem_margin, axis=1)
            over &= (point_region == top) & (z >= hi[low, 2] - cfg.support_band) & (z <= hi[low, 2] + cfg.stem_gap)
            if int(over.sum()) < cfg.min_contacts or not _hangs(sp, point_region, low, lo[low], hi[low], planes, cfg):
                continue
            if _out_from_wall(sp.points[point_region == low], planes) < cfg.bracket_min_depth:
                continue  # flat on the wall: a picture or a mirror hung under a shelf
            remap[low] = top
            joined += 1
    return remap[region], joined
