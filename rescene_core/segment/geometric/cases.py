"""Bodies stored in cases: a book stack parted from its bookcase's back and sides at creases and
where the colour leaves the case's own, rows of books that stay with the case, and regions parted
by creases alone that join again when one lies within the other."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.colour import _hue_rest
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import (
    ScanPoints,
    _facing_up,
    _point_parts,
    _region_bounds,
    _touching_regions,
    points_by_region,
)
from rescene_core.segment.geometric.support import _board_share, _held_by_top, _rests_on, _stored_upright, _under_board


def _stored_bodies(
    sp: ScanPoints,
    stuck: NDArray[np.bool_],
    far_below: NDArray[np.bool_],
    mine: NDArray[np.bool_],
    h: float,
    slab: NDArray[np.bool_],
    cfg: SegmentConfig,
    shelves: tuple[NDArray, NDArray] | None = None,
) -> list[NDArray[np.bool_]]:
    """Bodies stored on a shelf of a case, which the point graph joins to the case's back, sides or edges
    (a book stack against a bookcase's back panel, flush with the shelf's front edge).

    ``stuck`` [n]: the region's points above the top at height ``h`` (m) whose part of the point graph reaches
    below the top or failed the test of a body on the top (a case's frame over its shelf, joined to
    nothing under it, with the stacks touching it); ``far_below`` [n]: the region's points more than
    ``support_band`` under the top (a leg, a side panel); ``mine`` [n]: the region's points; ``slab`` [n]:
    the top's points; ``shelves``: the x, y bounds [2] of the region's tops at every height. The stuck
    points in columns of the case's frame (``_frame_columns``: its sides and back) are left to the case,
    and the rest parted into bodies twice (``_parted_bodies``): first at their concave creases
    (``ScanPoints.concave``: a body meets the case's back and the board over it at a concave corner; its
    own faces meet at convex ones), then what is left also where the colour changes between the case's own
    (``case_tint`` off the shelf's median colour) and another: where the fused surface rounds a corner, no
    crease parts a stack from the panel it stands flush with, but its colour does. Creases come first
    because a book of the case's colour in a stack is parted from the other books by colour and stays with
    the case. Returns the points [n] of each body."""
    # the case's sides and back rise unbroken from the shelf: taken off the stuck points, they no longer
    # join the bodies they touch (a stack flush with a side panel or against the back)
    stuck = stuck & ~_frame_columns(sp.points, stuck, h, cfg)
    if int(stuck.sum()) < cfg.min_segment_points:
        return []
    case = sp.points[mine]
    # the case's wood or paint, lit or shaded, against the colours of what is stored on it
    own = np.zeros(len(mine), bool)
    own[mine] = _hue_rest(sp.colours[mine], np.median(sp.colours[slab], axis=0))[1] < cfg.case_tint
    bodies = _parted_bodies(sp, stuck, far_below, h, slab, case, own, shelves, cfg)
    left = stuck.copy()
    for body in bodies:
        left &= ~body
    if int(left.sum()) < cfg.min_segment_points:
        return bodies
    return bodies + _parted_bodies(sp, left, far_below, h, slab, case, own, shelves, cfg, by_colour=True)


def _parted_bodies(
    sp: ScanPoints,
    stuck: NDArray[np.bool_],
    far_below: NDArray[np.bool_],
    h: float,
    slab: NDArray[np.bool_],
    case: NDArray,
    own: NDArray[np.bool_],
    shelves: tuple[NDArray, NDArray] | None,
    cfg: SegmentConfig,
    by_colour: bool = False,
) -> list[NDArray[np.bool_]]:
    """The bodies the ``stuck`` points [n] over a top at height ``h`` (m) part into at the concave creases
    and, ``by_colour``, where ``own`` [n] (each point of the case's colour or not) changes too (see
    ``_stored_bodies``; ``far_below``, ``slab`` as there; ``case`` [k, 3]: the case's points; ``shelves``:
    the lower and upper x, y bounds [2] of the case's tops at every height).

    A part beginning on the top and touching nothing far under it seeds a body, and the touching parts
    within its footprint grown by ``top_margin`` join it (the books of a stack, a stack on a stack). Parted
    by colour, a part of the other colour class joins only when it ends ``frame_column_rise`` over the top
    at most (a book of the case's colour in a stack, not a piece of the frame over it). A body is stored
    when it has ``min_segment_points`` points, its centre lies over the top's seen bounds (or over the
    bounds of the case's ``shelves`` seen at every height, when under half its points are of the case's
    colour: a stack at a shelf's end, the end hidden behind it, seen on the shelves over and
    under it; a piece of the case's side there has its colour), the top is seen
    beyond it on ``stored_top_sides`` sides (``_held_by_top``), it is ``body_min_thickness`` thick every
    way, is not upright (``_stored_upright``: a row of books standing in a bookcase is the bookcase's),
    nor, parted by colour, the case's own books (``_case_books``), and has a board of the case over
    ``stored_board_share`` of its footprint (``_board_share``; what has nothing over it, a sofa's back
    cushion, is the piece's own; parted by colour, only the case's colour is a board: a table seen over a
    chair's seat in one region is none). Returns the points [n] of each body."""
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    inner = stuck[i0] & stuck[i1]
    keep = ~sp.concave & (own[i0] == own[i1]) if by_colour else ~sp.concave
    boards = sp.points[own] if by_colour else case  # ``own`` holds the case's points alone
    k, part = _point_parts(sp.edges, stuck, keep)
    sub = part[stuck]
    p = sp.points[stuck]
    lo = np.full((k, 3), np.inf)
    hi = np.full((k, 3), -np.inf)
    np.minimum.at(lo, sub, p)
    np.maximum.at(hi, sub, p)
    count = np.bincount(sub, minlength=k)
    held = np.zeros(k, bool)  # parts touching the region far under the top
    held[part[i0[stuck[i0] & far_below[i1]]]] = True
    held[part[i1[stuck[i1] & far_below[i0]]]] = True
    cross = inner & (part[i0] != part[i1])
    colour = np.zeros(k, bool)
    if by_colour:
        colour[sub] = own[stuck]  # one class a part: ``keep`` cuts where it changes
    neighbours: dict[int, set[int]] = {}
    for a, b in zip(part[i0[cross]].tolist(), part[i1[cross]].tolist(), strict=True):
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    top = sp.points[slab, :2]
    tlo, thi = top.min(axis=0), top.max(axis=0)
    clo, chi = (np.minimum(tlo, shelves[0]), np.maximum(thi, shelves[1])) if shelves is not None else (tlo, thi)
    seeds = np.flatnonzero(~held & (lo[:, 2] <= h + cfg.support_band) & (count >= cfg.min_contacts))
    taken = held.copy()
    bodies = []
    for s in seeds[np.argsort(-count[seeds], kind="stable")].tolist():
        if taken[s]:
            continue
        body, blo, bhi = [s], lo[s].copy(), hi[s].copy()
        frontier = [s]
        while frontier:
            grown = []
            for c in frontier:
                for t in neighbours.get(c, ()):
                    if taken[t] or t in body:
                        continue
                    within = np.all(lo[t, :2] >= blo[:2] - cfg.top_margin) & np.all(
                        hi[t, :2] <= bhi[:2] + cfg.top_margin
                    )
                    if within and (colour[t] == colour[s] or hi[t, 2] <= h + cfg.frame_column_rise):
                        body.append(t)
                        grown.append(t)
                        blo, bhi = np.minimum(blo, lo[t]), np.maximum(bhi, hi[t])
            frontier = grown
        blo[2] = h  # it stands on the top: its height counts from there
        if count[body].sum() < cfg.min_segment_points or float(np.min(bhi - blo)) < cfg.body_min_thickness:
            continue
        centre = 0.5 * (blo[:2] + bhi[:2])
        if (
            np.any(centre < clo)
            or np.any(centre > chi)
            or not _held_by_top(blo, bhi, top, cfg, least=cfg.stored_top_sides)
        ):
            continue  # beside the shelf, the shelf seen nowhere beyond it, or spanned both ways
        points = np.isin(part, body)
        if (np.any(centre < tlo) or np.any(centre > thi)) and float(own[points].mean()) >= 0.5:
            continue  # at a shelf's end seen only over and under it, of the case's colour: a piece of the case
        if by_colour and _case_books(sp, points, bhi[2] - blo[2], np.min(bhi[:2] - blo[:2]), cfg):
            continue  # parted by colour alone, upright or a row: the case's own books, a piece of its frame
        if _stored_upright(case, blo, bhi, cfg) and not _in_layers(sp, points, cfg):
            continue  # books standing in a row: the bookcase's own
        if _board_share(boards, blo, bhi, cfg) < cfg.stored_board_share:
            continue  # nothing of the case over it: a cushion against a sofa's back
        taken[body] = True
        bodies.append(points)
    return bodies


def _frame_columns(points: NDArray, stuck: NDArray[np.bool_], h: float, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Which of the ``stuck`` points [n] (``points`` [n, 3], m) stand in a column of the case's frame over its
    top at height ``h`` (m): a ``superpoint_voxel`` square column whose points fill every
    ``frame_column_bin`` of height, from its lowest point over ``top_clearance`` above the top up to
    ``frame_column_rise`` over the top, ``frame_column_least`` bins at least (a side or back panel rises
    unbroken past the shelf's bodies, seen from the shelf or only above what stands in front of it; a
    stack's column breaks between its top and the board over it)."""
    idx = np.flatnonzero(stuck)
    frame = np.zeros(len(points), bool)
    if len(idx) == 0:
        return frame
    q = points[idx]
    ij = np.floor(q[:, :2] / cfg.superpoint_voxel).astype(np.int64)
    ij -= ij.min(axis=0)
    _, column = np.unique(ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1], return_inverse=True)
    bins = int(round(cfg.frame_column_rise / cfg.frame_column_bin))
    level = np.floor((q[:, 2] - h - cfg.top_clearance) / cfg.frame_column_bin).astype(np.int64)
    within = (level >= 0) & (level < bins)
    filled = np.zeros((int(column.max()) + 1, bins), bool)
    filled[column[within], level[within]] = True
    # the bins filled without a break down from the top one, and the lowest bin filled at all: a panel seen
    # only above what stands in front of it runs unbroken from there
    run = np.cumprod(filled[:, ::-1], axis=1).sum(axis=1)
    first = np.argmax(filled, axis=1)
    frame[idx] = ((run == bins - first) & (run >= cfg.frame_column_least))[column]
    return frame


def _seams(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> tuple[int, float]:
    """How many point edges within a body's points ``body`` [n] step ``layer_colour_step`` in colour, and
    the share of them that run more up than across (0 when none)."""
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    seam = body[i0] & body[i1] & (sp.colour_step >= cfg.layer_colour_step)
    if not seam.any():
        return 0, 0.0
    d = sp.points[i1[seam]] - sp.points[i0[seam]]
    return int(seam.sum()), float((np.abs(d[:, 2]) > np.linalg.norm(d[:, :2], axis=1)).mean())


def _in_layers(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> bool:
    """Whether a body's points ``body`` [n] change colour across horizontal seams: ``layer_share`` or more of
    the point edges within it that step ``layer_colour_step`` in colour run more up than across, over
    ``layer_min_edges`` of them (books lying flat; the seams of books standing upright are vertical)."""
    seams, rising = _seams(sp, body, cfg)
    return seams >= cfg.layer_min_edges and rising >= cfg.layer_share


def _case_books(sp: ScanPoints, body: NDArray[np.bool_], tall: float, narrow: float, cfg: SegmentConfig) -> bool:
    """Whether a body parted from its case by colour alone, ``tall`` over its shelf and ``narrow`` across its
    narrower side (m), is the case's own: its colour seams in rows (``_in_rows``) and ``row_min_height``
    tall (books standing upright), or taller than ``narrow`` and not in layers (``_in_layers``: a tall
    stack lies in layers). ``body`` [n]: its points."""
    seams, rising = _seams(sp, body, cfg)  # once for both tests
    counted = seams >= cfg.layer_min_edges
    in_rows, in_layers = counted and rising < cfg.layer_share, counted and rising >= cfg.layer_share
    return (tall >= cfg.row_min_height and in_rows) or (tall >= narrow and not in_layers)


def _in_rows(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> bool:
    """Whether a body's points ``body`` [n] change colour across vertical seams: over ``layer_min_edges`` point
    edges within it step ``layer_colour_step`` in colour and fewer than ``layer_share`` of them run more up
    than across (books standing upright in a row; a stack of two books shows too few seams to tell)."""
    seams, rising = _seams(sp, body, cfg)
    return seams >= cfg.layer_min_edges and rising < cfg.layer_share


def _join_stored_rows(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """A region that touches a larger one and stands within its bounds (footprint within ``top_margin``,
    above its lowest point and under its highest), upright under a board of it (``_stored_upright``) and not
    in layers (``_in_layers``), joins it: a row of books standing in a bookcase that the graph never joined
    to the case is the case's, as ``_stored_bodies`` leaves such a row to the case when it is. A book stack
    lies flat or shows its layers, and stays apart. ``region`` [s] (0: none); returns the regions and how
    many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    size = np.bincount(region, g.count, n)
    point_region = region[g.label]
    by_region, start = points_by_region(point_region, n)
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts):
        r, case = (a, b) if size[a] < size[b] else (b, a)
        if remap[r] != r or remap[case] != case:
            continue
        within = np.all(lo[r, :2] >= lo[case, :2] - cfg.top_margin) and np.all(
            hi[r, :2] <= hi[case, :2] + cfg.top_margin
        )
        if not within or lo[r, 2] < lo[case, 2] or hi[r, 2] >= hi[case, 2]:
            continue
        case_points = sp.points[by_region[start[case] : start[case + 1]]]
        if _stored_upright(case_points, lo[r], hi[r], cfg) and not _in_layers(sp, point_region == r, cfg):
            remap[r] = case
            joined += 1
    while np.any(remap[remap] != remap):  # a row joined to a region that itself joined a larger one
        remap = remap[remap]
    return remap[region], joined


def _rejoin_enclosed(
    sp: ScanPoints,
    region: NDArray[np.int64],
    creased: NDArray[np.bool_],
    near_structure: NDArray[np.bool_],
    cfg: SegmentConfig,
    by_extent: bool = False,
) -> tuple[NDArray[np.int64], int]:
    """Regions parted only by creases (``creased`` [p]: contacts cut for their concavity alone) join again
    when the smaller lies within the larger's bounds (``enclosed_fraction`` of its points by superpoint
    centroid): the shelves inside a bookcase's frame, the mattress inside a bed's frame. Nothing joins a
    region lying mostly along the structure (``near_structure`` [s]: superpoints by a wall, the floor or the
    ceiling), whose bounds span a wall, nor a region standing on a top of the larger one (``_rests_on``: a
    book stack on a shelf, a lamp on a nightstand). The smaller of two is the one with fewer points, or with
    ``by_extent`` the one with the shorter bounding-box diagonal (a picture's canvas has more points than
    its frame). Returns the regions and how many joined."""
    g = sp.graph
    region = region.copy()
    joined = 0
    up = _facing_up(sp.normals)
    for _ in range(3):
        n = int(region.max()) + 1
        lo, hi = _region_bounds(g, region, n)
        pts = np.bincount(region, g.count, n)
        along = np.bincount(region, g.count * near_structure, n) >= 0.5 * pts
        ra, rb = region[g.pairs[creased, 0]], region[g.pairs[creased, 1]]
        ok = (ra > 0) & (rb > 0) & (ra != rb)
        cand = {(min(a, b), max(a, b)) for a, b in zip(ra[ok].tolist(), rb[ok].tolist(), strict=True)}
        # the upward-facing points of each region, for the test of what stands on what
        point_region = region[g.label]
        up_idx = np.flatnonzero(up & (point_region > 0))
        up_idx = up_idx[np.argsort(point_region[up_idx], kind="stable")]
        up_bounds = np.searchsorted(point_region[up_idx], np.arange(n + 1))
        remap = np.arange(n)
        changed = False
        size = np.linalg.norm(hi - lo, axis=1) if by_extent else pts
        for a, b in sorted(cand):
            small, big = (a, b) if size[a] < size[b] else (b, a)
            if remap[small] != small or remap[big] != big or along[big] or along[small]:
                continue  # one of them joined another region in this round
            mine = region == small
            c = g.centroid[mine]
            inside = np.all((c >= lo[big]) & (c <= hi[big]), axis=1)
            if (g.count[mine] * inside).sum() < cfg.enclosed_fraction * pts[small]:
                continue
            tops = sp.points[up_idx[up_bounds[big] : up_bounds[big + 1]]]
            if not by_extent:
                case = sp.points[point_region == big]
                low = cfg.stored_min_height if _under_board(case, lo[small], hi[small], cfg) else cfg.support_min_height
                if _rests_on(tops, lo[small], hi[small], lo[big], hi[big], low, cfg):
                    if not _stored_upright(case, lo[small], hi[small], cfg):
                        continue  # a book stack on a shelf of its bookcase, a lamp on its nightstand
            remap[small] = big
            joined += 1
            changed = True
        region = remap[region]
        if not changed:
            break
    return region, joined
