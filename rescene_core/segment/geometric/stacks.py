"""A stack on a stack: a small region resting on something that narrows sharply at some height is
two bodies, cut there."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import ScanPoints, _regrouped, points_by_region


def split_stacked(
    sp: ScanPoints, region: NDArray[np.int64], which: NDArray[np.int64], cfg: SegmentConfig
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """A body resting on a narrower one, both small, is split off it at the height where the region
    narrows (``_stack_cut``): a book stack on a book stack. The upper stack's ring of the lower one's top
    is too narrow and too little seen to be a top (``split_bodies_on_tops``), but the step in width is
    plain. A region is a candidate when it is at most ``stacked_max_width`` and at least
    ``min_segment_extent`` wide both ways, on the floor as on a table or a shelf (a potted plant's
    foliage narrowing upward over its pot is kept whole by ``_flares``). ``region`` [s] (0: none),
    ``which`` [s]: the wall of each superpoint (0: none). Returns the scan points with the new superpoint
    graph, the region and wall of each new superpoint, and how many bodies were split."""
    g = sp.graph
    point_region = region[g.label].copy()
    n = int(region.max(initial=0)) + 1
    order, bounds = points_by_region(point_region, n)
    nxt, split = n, 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < cfg.min_segment_points:
            continue
        p = sp.points[idx]
        lo, hi = p.min(axis=0), p.max(axis=0)
        wide = hi[:2] - lo[:2]
        if wide.max() > cfg.stacked_max_width or wide.min() < cfg.min_segment_extent:
            continue
        cut = _stack_cut(p, cfg)
        if cut is None:
            continue
        point_region[idx[p[:, 2] >= cut]] = nxt
        nxt += 1
        split += 1
    return _regrouped(sp, region, which, point_region, split)


def _stack_cut(p: NDArray, cfg: SegmentConfig) -> float | None:
    """The height (m) at which a small region's points ``p`` [k, 3] part into a body resting on a wider one,
    or None. Heights are tried every centimetre from ``stacked_min_part`` over the foot to as far under the
    top; at each, the narrowing is the larger of two ratios, each the widest of x and y: the extent of the
    points above over that of those below, and of the ``stacked_slice`` above over the slice below. The
    height of least narrowing is the cut when it is at most ``stacked_narrowing``, the centre of the points
    above lies over those below, both sides hold ``stacked_min_points`` (``min_segment_points`` below, so
    the lower body stays a segment) and each slice ``stacked_slice_points``, and the slice below is at most
    ``stacked_max_flare`` as wide as the ``stacked_slice`` at the foot (``_flares``)."""
    z = p[:, 2]
    foot = p[z < z.min() + cfg.stacked_slice, :2]
    best, cut = cfg.stacked_narrowing, None
    for h in np.arange(z.min() + cfg.stacked_min_part, z.max() - cfg.stacked_min_part + 1e-9, 0.01):
        below, above = p[z < h], p[z >= h]
        if len(below) < max(cfg.min_segment_points, cfg.stacked_min_points) or len(above) < cfg.stacked_min_points:
            continue
        under = below[below[:, 2] >= h - cfg.stacked_slice, :2]
        over = above[above[:, 2] < h + cfg.stacked_slice, :2]
        if min(len(under), len(over)) < cfg.stacked_slice_points:
            continue
        blo, bhi = below[:, :2].min(axis=0), below[:, :2].max(axis=0)
        whole = np.ptp(above[:, :2], axis=0) / np.maximum(bhi - blo, 1e-6)
        step = np.ptp(over, axis=0) / np.maximum(np.ptp(under, axis=0), 1e-6)
        narrowing = float(max(whole.max(), step.max()))
        centre = above[:, :2].mean(axis=0)
        if narrowing <= best and not _flares(under, foot, cfg) and np.all(centre > blo) and np.all(centre < bhi):
            best, cut = narrowing, float(h)
    return cut


def _flares(under: NDArray, foot: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a body flares out upward: the slice under a cut ``under`` [k, 2] (x, y, m) is more than
    ``stacked_max_flare`` as wide as the slice at its foot ``foot`` [f, 2], the wider of x and y (a pot under
    spreading foliage). A foot of fewer than ``stacked_slice_points`` points tells nothing."""
    if len(foot) < cfg.stacked_slice_points:
        return False
    return float(np.max(np.ptp(under, axis=0) / np.maximum(np.ptp(foot, axis=0), 1e-6))) > cfg.stacked_max_flare
