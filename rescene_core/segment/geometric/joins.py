"""Regions that join others: lamp stems under their shades, pillows on a mattress, legs under a top,
backs against a wall, and pieces too small or too thin to stand alone."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import (
    ScanPoints,
    _facing_up,
    _region_bounds,
    _touching_regions,
    points_by_region,
)
from rescene_core.segment.geometric.support import _hangs_over
from rescene_core.segment.geometric.walls import _hangs
from rescene_core.segment.superpoints import SuperpointGraph


def _join_stems(
    sp: ScanPoints,
    region: NDArray[np.int64],
    cfg: SegmentConfig,
    planes: list[dict[str, Any]],
    split_from: int = 0,
) -> tuple[NDArray[np.int64], int]:
    """A region below another, its top between ``support_band`` above the other's lowest point and
    ``stem_gap`` under it, joins that one when its upper end (the points within ``support_band`` of its top)
    lies under the other's footprint (within ``stem_margin``) and is narrower than ``stem_width_fraction`` of
    the other both ways, and at least ``stem_overlap`` of its own footprint lies under the other's: a table
    lamp's base and stem under its shade, parted from it by the shade's colour and the crease at the rim, or
    by a gap where the fusion lost the stem's thin top (an angled arm, a base broader than the shade). A book
    stack under another has a top as broad as itself and stays apart. A region joins however broad its upper
    end when the other reaches ``top_margin`` past that end on every side (a plant's pot under its foliage)
    or when it hangs (``_hangs``: a wall shelf's bracket, parted from the board by its colour). What
    overhangs a region all round may begin lower than its top when what hangs that low lies beside the
    region, not over it (``_hangs_over``: leaves hanging beside the pot). With ``split_from`` > 0 (run
    after the splits, the first id of the bodies they split off) only those bodies join, and only as stems
    narrower than ``leg_width`` at their upper end, to regions numbered below it: a lamp's base and stem
    split off its nightstand's top join its shade; a stack split off a bookcase's shelf stays apart from
    the books standing on the board over it. ``region`` [s] (0: none); returns the regions and how many
    joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    point_region = region[g.label]
    gap = lo[None, :, 2] - hi[:, None, 2]  # [low, top]: from the low one's top up to the other's lowest point
    above = lo[:, None, 2] < lo[None, :, 2]
    under = (gap >= -cfg.support_band) & (gap <= cfg.stem_gap) & above
    # what overhangs a region all round may hang lower than the region's top beside it (foliage over its pot)
    around = (lo[None, :, :2] + cfg.top_margin <= lo[:, None, :2]).all(axis=2)
    around &= (hi[:, None, :2] <= hi[None, :, :2] - cfg.top_margin).all(axis=2)
    droop = around & (gap < -cfg.support_band) & above & (split_from == 0)
    under |= droop
    under[0, :] = under[:, 0] = False
    if split_from:
        under[:split_from, :] = under[:, split_from:] = False
    lows, tops = np.nonzero(under)
    cover = np.clip(np.minimum(hi[lows, :2], hi[tops, :2] + cfg.stem_margin)
                    - np.maximum(lo[lows, :2], lo[tops, :2] - cfg.stem_margin), 0.0, None).prod(axis=1)  # fmt: skip
    area = np.maximum(np.prod(hi[lows, :2] - lo[lows, :2], axis=1), 1e-6)
    keep = cover >= cfg.stem_overlap * area
    lows, tops = lows[keep], tops[keep]
    order = np.argsort(np.abs(gap[lows, tops]), kind="stable")  # the nearest one over it first
    by_region, start = points_by_region(point_region, n)
    remap = np.arange(n)
    joined = 0
    for low, top in zip(lows[order].tolist(), tops[order].tolist(), strict=True):
        if remap[low] != low or remap[top] != top:
            continue
        p = sp.points[by_region[start[low] : start[low + 1]]]
        end = p[p[:, 2] >= hi[low, 2] - cfg.support_band, :2]
        if droop[low, top] and _hangs_over(p, sp.points[by_region[start[top] : start[top + 1]]], hi[low, 2], cfg):
            continue  # what hangs lower than its top lies over it, not beside it
        end_lo, end_hi = end.min(axis=0), end.max(axis=0)
        if np.any(end_lo < lo[top, :2] - cfg.stem_margin) or np.any(end_hi > hi[top, :2] + cfg.stem_margin):
            continue  # its upper end reaches out from under the other (a floor lamp's arm beside a shelf)
        if split_from and np.any(end_hi - end_lo > cfg.leg_width):
            continue
        broad = np.any(end_hi - end_lo > cfg.stem_width_fraction * (hi[top, :2] - lo[top, :2]))
        # a plant's foliage overhangs its pot all round; a stack on a stack is no broader than the one under it
        overhung = split_from == 0 and bool(
            np.all(end_lo >= lo[top, :2] + cfg.top_margin) and np.all(end_hi <= hi[top, :2] - cfg.top_margin)
        )
        if broad and not overhung and not _hangs(sp, point_region, low, lo[low], hi[low], planes, cfg):
            continue  # a broad top: a body under the other (a book stack under another), not a stem
        remap[low] = top
        joined += 1
    return remap[region], joined


def _bedding_top(tops: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a body with bounds ``lo``, ``hi`` [3] (m) lies on a mattress: the upward-facing points ``tops``
    [k, 3] of the region it touches, from ``support_band`` below its lowest height to ``bedding_duvet`` above
    it, form a level between ``bedding_min_height`` and ``bedding_max_height`` above the floor, at least
    ``bedding_min_length`` by ``bedding_min_width`` across, that reaches beyond the body both ways and lies
    under its footprint (``min_contacts`` points)."""
    level = tops[(tops[:, 2] >= lo[2] - cfg.support_band) & (tops[:, 2] <= lo[2] + cfg.bedding_duvet)]
    if len(level) < cfg.top_min_points:
        return False
    height = float(np.median(level[:, 2]))
    if not cfg.bedding_min_height <= height <= cfg.bedding_max_height:
        return False
    span = np.ptp(level[:, :2], axis=0)
    if span.max() < cfg.bedding_min_length or span.min() < cfg.bedding_min_width:
        return False
    if np.any(hi[:2] - lo[:2] >= span):
        return False  # as broad as the top one way: the mattress itself on its frame, not bedding on it
    grown_lo, grown_hi = lo[:2] - cfg.support_band, hi[:2] + cfg.support_band
    under = np.all((level[:, :2] >= grown_lo) & (level[:, :2] <= grown_hi), axis=1)
    return int(under.sum()) >= cfg.min_contacts


def _join_bedding(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """A low flat region (no taller than ``bedding_flatness`` of its smaller horizontal extent) lying on a
    mattress of a region it touches (``_bedding_top``) joins that region: a bed's pillows, parted from the
    mattress by the support cut, by the split at a top or by their colour, are part of the bed. A monitor or
    a lamp stands taller than it is deep; a book stack lies on a top too small or too high for a mattress; a
    sofa's seat is shallower than a mattress and its back cushions stand upright. ``region`` [s] (0: none);
    returns the regions and how many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    flat = (hi[:, 2] - lo[:, 2]) <= cfg.bedding_flatness * (hi[:, :2] - lo[:, :2]).min(axis=1)
    point_region = region[g.label]
    up = _facing_up(sp.normals)
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, among=flat):
        for body, bed in ((a, b), (b, a)):
            if not flat[body] or remap[body] != body or remap[bed] != bed:
                continue
            if _bedding_top(sp.points[up & (point_region == bed)], lo[body], hi[body], cfg):
                remap[body] = bed
                joined += 1
    for _ in range(3):  # a pillow joins a region that may itself have joined another: follow the chain
        remap = remap[remap]
    return remap[region], joined


def _attach_legs(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """Slender upright regions (narrower than ``leg_max_width`` one way or both, twice as tall as that) whose
    upper end lies just under a broader region join it: the legs and side panels of a table or a desk, cut
    off at the crease under its top, or parted from it by a gap the fusion left. The broader region has
    ``min_contacts`` points or more above the upright's footprint (grown by ``support_band``) between
    ``support_band`` below its upper end and three times that above, and its bounds contain that footprint;
    with no surface there, the smallest region whose bounds hold the upright's upper end and footprint and
    begin at most three ``support_band`` below that end (a floor lamp's pole reaching into its open shade).
    Returns the regions and how many joined."""
    g = sp.graph
    region = region.copy()
    n = int(region.max()) + 1
    point_region = region[g.label]
    lo, hi = _region_bounds(g, region, n)
    span = hi - lo
    narrow = span[:, :2].min(axis=1)
    slender = (narrow <= cfg.leg_max_width) & (span[:, 2] >= 2 * narrow) & (np.arange(n) > 0)
    slender &= lo[:, 2] <= cfg.support_min_height  # it stands on the floor, or nearly
    joined = 0
    remap = np.arange(n)
    band = cfg.support_band
    for r in np.flatnonzero(slender).tolist():
        near = np.all((sp.points[:, :2] >= lo[r, :2] - band) & (sp.points[:, :2] <= hi[r, :2] + band), axis=1)
        near &= (sp.points[:, 2] >= hi[r, 2] - band) & (sp.points[:, 2] <= hi[r, 2] + 3 * band)
        owners = point_region[near]
        owners = owners[(owners > 0) & (owners != r)]
        top = int(np.bincount(owners).argmax()) if len(owners) else 0
        if len(owners) < cfg.min_contacts or np.bincount(owners)[top] < cfg.min_contacts or slender[top]:
            # no surface just above it: its upper end may reach into a hollow region hanging over it (a
            # floor lamp's pole ends inside its open shade, whose surface lies beyond the pole's footprint)
            top = _hollow_over(r, lo, hi, slender, band)
            if top == 0:
                continue
        inside = np.all(lo[top, :2] - band <= lo[r, :2]) and np.all(hi[r, :2] <= hi[top, :2] + band)
        if inside and hi[top, 2] > hi[r, 2] + band:
            remap[r] = top
            joined += 1
    # a leg joins a top that may itself have joined another: follow the chain
    for _ in range(3):
        remap = remap[remap]
    return remap[region], joined


def _attach_backs(
    sp: ScanPoints, region: NDArray[np.int64], planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[NDArray[np.int64], int]:
    """Regions standing near the floor and lying wholly within ``back_depth`` in front of one wall, with a
    broader region's surface over them (``min_contacts`` points or more above their footprint, grown by
    ``support_band``, from ``support_band`` under their upper end to ``back_reach`` over it), join the region
    that holds at least ``stem_overlap`` of their stretch along the wall and rises past their upper end: a
    desk's back legs and back rail, fused with the wall they stand against, whose upper part the fusion gave
    to the wall (so that the leg ends short of the top) and whose smear along the wall reaches past the
    desk's end. Whatever stands against the wall under a desk deeper than ``back_depth`` (a bin, a drawer
    unit) stays apart.
    A region within ``back_depth`` of a wall reaching from under the top of a region it touches
    (``min_contacts`` graph contacts) to over it, that region holding that share of its stretch and it
    spanning ``support_span_fraction`` of that region's, joins it (a mirror standing behind a desk is
    narrower than the desk): a bed's headboard, its lower part hidden behind the bed, upright as a monitor
    on a desk and parted from the bedding by colour and the crease where the mattress meets it. Returns the
    regions and how many joined."""
    g = sp.graph
    walls = [(np.asarray(q["normal"], float), float(q["offset"])) for q in planes if q["kind"] == "wall"]
    n = int(region.max(initial=0)) + 1
    if not walls or n <= 1:
        return region, 0
    point_region = region[g.label]
    lo, hi = _region_bounds(g, region, n)
    by_region, start = points_by_region(point_region, n)
    # the depth of each region in front of each wall: the larger of its 95th-percentile distance either side
    depth = np.full(n, np.inf)
    wall_of = np.zeros(n, np.int64)
    count = np.diff(start)
    k95 = start[:-1] + np.maximum(np.ceil(0.95 * count).astype(np.int64) - 1, 0)
    has = count > 0
    for i, (normal, offset) in enumerate(walls):
        d = np.abs(sp.points @ normal + offset)
        srt = np.argsort(point_region * 1.0 + np.minimum(d, 0.999), kind="stable")  # by region, then distance
        nearer = has & (d[srt[k95]] < depth)
        depth[nearer] = d[srt[k95[nearer]]]
        wall_of[nearer] = i
    against = (depth <= cfg.back_depth) & (np.arange(n) > 0)
    back = against & (lo[:, 2] <= cfg.support_min_height)

    def along_share(r: int, other: int, wall: int) -> float:
        """Share of region r's stretch along a wall that lies within the other's (grown by ``support_band``)."""
        normal = walls[wall][0]
        horiz = np.array([-normal[1], normal[0], 0.0])
        a = sp.points[by_region[start[r] : start[r + 1]]] @ horiz
        b = sp.points[by_region[start[other] : start[other + 1]]] @ horiz
        cover = min(a.max(), b.max() + cfg.support_band) - max(a.min(), b.min() - cfg.support_band)
        return max(cover, 0.0) / max(float(np.ptp(a)), 1e-3)

    remap = np.arange(n)
    joined = 0
    band = cfg.support_band
    for r in np.flatnonzero(back).tolist():
        over = np.all((sp.points[:, :2] >= lo[r, :2] - band) & (sp.points[:, :2] <= hi[r, :2] + band), axis=1)
        over &= (sp.points[:, 2] >= hi[r, 2] - band) & (sp.points[:, 2] <= hi[r, 2] + cfg.back_reach)
        owners = point_region[over]
        owners = owners[(owners > 0) & (owners != r) & ~back[owners]]
        if len(owners) < cfg.min_contacts:
            continue
        top = int(np.bincount(owners).argmax())
        if np.bincount(owners)[top] < cfg.min_contacts or hi[top, 2] <= hi[r, 2]:
            continue
        if along_share(r, top, wall_of[r]) >= cfg.stem_overlap:
            remap[r] = top
            joined += 1
    # a region against the wall reaching from below the top of a region it touches to over it, that region
    # holding its stretch: a bed's headboard (its lower part hidden behind the bed)
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, among=against):
        for r, nb in ((a, b), (b, a)):
            if not against[r] or against[nb] or remap[r] != r:
                continue
            if lo[r, 2] >= hi[nb, 2] - band or hi[r, 2] <= hi[nb, 2] + band:
                continue
            # and spans it (a mirror standing behind a desk, narrower than the desk, is no part of it)
            w = wall_of[r]
            if along_share(r, nb, w) >= cfg.stem_overlap and along_share(nb, r, w) >= cfg.support_span_fraction:
                remap[r] = nb
                joined += 1
    for _ in range(3):
        remap = remap[remap]
    return remap[region], joined


def _hollow_over(r: int, lo: NDArray, hi: NDArray, slender: NDArray[np.bool_], band: float) -> int:
    """The region (0: none) whose bounds ``lo``, ``hi`` [n, 3] (m) hold region r's upper end and footprint and
    begin within three ``band`` below that end: what r reaches up into. The smallest such region wins."""
    cand = (lo[:, :2] - band <= lo[r, :2]).all(axis=1) & (hi[r, :2] <= hi[:, :2] + band).all(axis=1)
    cand &= (lo[:, 2] >= hi[r, 2] - 3 * band) & (lo[:, 2] <= hi[r, 2] + band) & (hi[:, 2] > hi[r, 2] + band)
    cand &= ~slender & (np.arange(len(lo)) > 0)
    cand[r] = False
    if not cand.any():
        return 0
    volume = np.prod(np.where(cand[:, None], hi - lo, np.inf), axis=1)
    return int(np.argmin(volume))


def _absorb_small(g: SuperpointGraph, region: NDArray[np.int64], cfg: SegmentConfig) -> NDArray[np.int64]:
    """Regions with fewer than ``min_segment_points`` points, and thin upright parts (legs, posts: narrower
    than ``leg_width`` and twice as tall as wide), join the touching region they share the most contacts
    with: the leg cut off at the crease under a table's top goes back to the table."""
    region = region.copy()
    for _ in range(3):
        n = int(region.max()) + 1
        pts = np.bincount(region, g.count, n)
        lo, hi = _region_bounds(g, region, n)
        width = (hi[:, :2] - lo[:, :2]).max(axis=1)
        thin = (width <= cfg.leg_width) & (hi[:, 2] - lo[:, 2] >= 2 * width)
        ra, rb = region[g.pairs[:, 0]], region[g.pairs[:, 1]]
        ok = (ra > 0) & (rb > 0) & (ra != rb)
        if not ok.any():
            break
        src = np.r_[ra[ok], rb[ok]]
        dst = np.r_[rb[ok], ra[ok]]
        w = np.r_[g.contacts[ok], g.contacts[ok]]
        small = (pts[src] < cfg.min_segment_points) | (thin[src] & ~thin[dst])
        if not small.any():
            break
        src, dst, w = src[small], dst[small], w[small]
        order = np.lexsort((-w, src))
        src, dst = src[order], dst[order]
        first = np.r_[True, src[1:] != src[:-1]]
        remap = np.arange(len(pts))
        for s_, d_ in zip(src[first].tolist(), dst[first].tolist(), strict=True):
            if remap[d_] != s_:  # do not let two small regions swap into each other
                remap[s_] = remap[d_]
        region = remap[region]
    return region
