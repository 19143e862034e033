"""Bodies standing on a top of their own region, split off at the top's plane (a monitor on a desk, a
book stack on a shelf)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from rescene_core.segment.geometric.cases import _stored_bodies
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import ScanPoints, _facing_up, _point_parts, _regrouped
from rescene_core.segment.geometric.support import _footprint, _held_by_top, _sides_at_wall, _top_heights


def split_bodies_on_tops(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which: NDArray[np.int64],
    cfg: SegmentConfig,
    planes: Sequence[dict[str, Any]] = (),
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """Bodies standing on a horizontal top of their region are split off it at the top's plane: a monitor
    on a desk (its base plate rises 3-7 cm, no crease and no colour step parts it), a lamp whose base disc
    fused into the top's superpoint, a book stack on a table.

    For each region (``region`` [s], 0: none) and each top of it (``_top_heights``: a slab of upward-facing
    points above ``support_min_height``), the region's points more than ``top_clearance`` above the top and
    over its bounds fall into connected parts of the point graph. A part is a body on the top when it has
    ``min_segment_points`` points, begins within ``support_band`` of the top, touches nothing of its region
    below the top (a side panel or a leg does), is narrower than ``support_span_fraction`` of the top both
    ways (a chair's back or a headboard spans its seat) and the top reaches beyond its footprint by
    ``top_margin`` on ``top_sides`` sides or more of the four (x and y in the aligned frame). Before that,
    pieces standing on the floor beside a high top are parted from it (``_pieces_beside_top``: chairs at a
    table); after it, the parts joined to the region below the top, and those that failed the body test,
    are searched for bodies stored on the top (``_stored_bodies``: a case's frame over its shelf holds
    them), and so are the parts beginning on the top whose centre lies beyond what is seen of it (a shelf
    at the cameras' height seen only along its front edge, the stack on it behind the edge). The tops are
    taken from the highest down: chairs pushed in at a table part from it at its top before their seats, a
    lower top of the same region, could carry the table as a body. A body split off is searched in turn
    for bodies on tops of its own (the upper part of a bookcase split off at a nightstand's top beside it,
    and the stacks on its shelves). Superpoints a body cuts are split. ``which`` [s]: the wall of each
    superpoint (0: none). Returns the scan points with the new superpoint graph, the region and wall of
    each new superpoint, and how many bodies and pieces were split."""
    g = sp.graph
    point_region = region[g.label].copy()
    up = _facing_up(sp.normals)
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    nxt = int(region.max(initial=0)) + 1
    split = 0
    off_wall = which[g.label] == 0  # a wall patch the region took in is neither a top nor a body
    z = sp.points[:, 2]
    walls = [q for q in planes if q["kind"] == "wall"]
    r = 0
    while r + 1 < nxt:  # a body split off a top is searched for tops of its own (a case's upper shelves)
        r += 1
        mine = (point_region == r) & off_wall
        if mine.sum() < 2 * cfg.min_segment_points:
            continue
        heights = _top_heights(z[mine & up], cfg, min(cfg.support_min_height, cfg.stored_min_height))
        # all the region's tops: a shelf's end hidden behind what stands there is seen on the shelves over it
        flat = np.flatnonzero(mine & up)
        near = np.abs(z[flat, None] - np.asarray(heights)[None, :]) <= cfg.support_band / 2
        shelf = sp.points[flat[near.any(axis=1)], :2]
        shelves = (shelf.min(axis=0), shelf.max(axis=0)) if len(shelf) else None
        for h in heights[::-1]:  # the highest first (see above)
            mine = (point_region == r) & off_wall
            slab = mine & up & (np.abs(z - h) <= cfg.support_band / 2)
            if slab.sum() < cfg.top_min_points:
                continue
            beside = _pieces_beside_top(sp, mine, slab, h, cfg)
            for piece in beside:
                point_region[piece] = nxt
                nxt += 1
                split += 1
            if beside:
                mine = (point_region == r) & off_wall
                slab &= mine
            tlo, thi = sp.points[slab, :2].min(axis=0), sp.points[slab, :2].max(axis=0)
            above = mine & (z > h + cfg.top_clearance)
            if above.sum() < cfg.min_segment_points:
                continue
            below = mine & (z < h - cfg.top_clearance)
            _, comp = _point_parts(sp.edges, above)
            # parts touching the region below the top (a leg, a side panel, a hutch's sides) are no bodies on it
            down = np.unique(np.r_[comp[i0[above[i0] & below[i1]]], comp[i1[above[i1] & below[i0]]]])
            ids, counts = np.unique(comp[above], return_counts=True)
            frame = list(down)  # parts of the piece's own above the top, which may hold stored bodies
            for c in ids[counts >= cfg.min_segment_points].tolist():
                if c in down or h < cfg.support_min_height:
                    continue
                body = above & (comp == c)
                p = sp.points[body]
                lo, hi = p.min(axis=0), p.max(axis=0)
                centre = p[:, :2].mean(axis=0)
                if lo[2] > h + cfg.support_band:
                    continue  # it does not stand on the top (a shelf board over it, a part beside it)
                if np.any(centre < tlo) or np.any(centre > thi):
                    frame.append(c)  # on a top seen only along its edge: it may hold stored bodies
                    continue
                foot = p[p[:, 2] <= lo[2] + cfg.foot_height]
                flo, fhi = foot.min(axis=0), foot.max(axis=0)
                if not _held_by_top(
                    lo, hi, sp.points[slab, :2], cfg, flo, fhi, walled=_sides_at_wall(flo, fhi, h, walls, cfg)
                ):
                    frame.append(c)  # a chair's back, a headboard, a hutch, a case's frame over its shelf
                    continue
                point_region[body] = nxt
                nxt += 1
                split += 1
            # what the region's frame holds fast above the top, or all above a top too low to carry bodies
            # of their own: a body stored on the shelf of a case
            stuck = above & (np.isin(comp, frame) | (h < cfg.support_min_height)) & (point_region == r)
            for body in _stored_bodies(sp, stuck, mine & (z < h - cfg.support_band), mine, h, slab, cfg, shelves):
                point_region[body] = nxt
                nxt += 1
                split += 1
    return _regrouped(sp, region, which, point_region, split)


def _pieces_beside_top(
    sp: ScanPoints, mine: NDArray[np.bool_], slab: NDArray[np.bool_], h: float, cfg: SegmentConfig
) -> list[NDArray[np.bool_]]:
    """Pieces of a region standing on the floor beside one of its high tops, outside the top's footprint:
    chairs at a dining table or a desk, whose backs come within a few centimetres of its edge (the fused
    surface bridges the gap).

    ``mine`` [n]: the region's points; ``slab`` [n]: the top's upward-facing points at height ``h`` (m).
    The top must be ``beside_min_height`` high, ``beside_min_width`` wide both ways and its footprint
    (``_footprint``) as large as a square of that side. The region's points more than ``beside_margin``
    outside the footprint's outline fall into connected parts of the point graph; a part is a piece of its
    own when it has ``min_segment_points`` points, reaches down to ``beside_floor_gap`` over the floor, has
    ``beside_rise_points`` points ``beside_rise`` over the top, is ``beside_min_tall`` tall and
    ``beside_piece_width`` wide both ways, and holds fewer than ``top_min_points`` of the top's points.
    Returns the points [n] of each piece."""
    top = sp.points[slab, :2]
    if h < cfg.beside_min_height or np.min(top.max(axis=0) - top.min(axis=0)) < cfg.beside_min_width:
        return []
    area, outline = _footprint(top, 2.0 * cfg.superpoint_voxel)  # every cell of a top seen whole holds points
    if area < cfg.beside_min_width**2:
        return []  # too little of it seen to tell its outline
    out = mine.copy()
    out[mine] = ~shapely.contains_xy(outline.buffer(cfg.beside_margin), sp.points[mine, 0], sp.points[mine, 1])
    n_out = int(out.sum())
    if n_out < cfg.min_segment_points:
        return []
    _, comp = _point_parts(sp.edges, out)
    ids, counts = np.unique(comp[out], return_counts=True)
    pieces = []
    for c in ids[counts >= cfg.min_segment_points].tolist():
        piece = comp == c
        p = sp.points[piece]
        lo, hi = p.min(axis=0), p.max(axis=0)
        rises = int((p[:, 2] > h + cfg.beside_rise).sum()) >= cfg.beside_rise_points
        if lo[2] > cfg.beside_floor_gap or not rises or hi[2] - lo[2] < cfg.beside_min_tall:
            continue  # not on the floor (a lamp's shade over the edge), or lower than the top (a case's side)
        if np.min(hi[:2] - lo[:2]) >= cfg.beside_piece_width and (piece & slab).sum() < cfg.top_min_points:
            pieces.append(piece)
    return pieces
