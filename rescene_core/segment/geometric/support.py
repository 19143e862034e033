"""The geometry of support: horizontal tops and their heights, footprints, which sides of a body a top
reaches beyond, boards of a case over a body, and what hangs over a footprint."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from shapely.geometry import MultiPoint, Polygon

from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.structure import _wall_coordinates


def _top_heights(z: NDArray[np.float64], cfg: SegmentConfig, min_height: float) -> list[float]:
    """Heights (m) of the horizontal tops among upward-facing points at heights ``z`` [k]: 1 cm bins with
    at least ``top_min_points`` points in a bin and its two neighbours, each the highest-count bin of its
    own neighbourhood, above ``min_height``."""
    z = z[z >= min_height]
    if len(z) < cfg.top_min_points:
        return []
    edges = np.arange(z.min() - 0.005, z.max() + 0.015, 0.01)
    hist = np.histogram(z, edges)[0]
    slab = hist + np.r_[0, hist[:-1]] + np.r_[hist[1:], 0]
    peak = (slab >= cfg.top_min_points) & (slab >= np.r_[0, slab[:-1]]) & (slab > np.r_[slab[1:], 0])
    out = []
    for i in np.flatnonzero(peak).tolist():
        near = np.abs(z - 0.5 * (edges[i] + edges[i + 1])) <= 0.015
        out.append(float(np.median(z[near])))
    return out


def _footprint(top: NDArray, cell: float) -> tuple[float, Polygon]:
    """The footprint of a top from its upward-facing points ``top`` [k, 2] (x, y, m) on a grid of ``cell`` (m):
    the cells holding points, gaps of a cell closed and strips narrower than three cells opened away (the
    rail of a chair's back level with a table's top). Returns the footprint's area (m^2) and the smallest
    rectangle around the points in its cells: what stands on the top hides it, at its edges and corners too,
    and may part what is seen of it in two (a cabinet's top with book stacks across it)."""
    origin = top.min(axis=0) - 3 * cell
    ij = np.floor((top - origin) / cell).astype(np.int64)
    grid = np.zeros(tuple(ij.max(axis=0) + 4), bool)
    grid[ij[:, 0], ij[:, 1]] = True
    foot = ndimage.binary_opening(ndimage.binary_closing(grid), np.ones((3, 3), bool))
    if not foot.any():
        return 0.0, Polygon()
    return float(foot.sum()) * cell**2, MultiPoint(top[foot[ij[:, 0], ij[:, 1]]]).oriented_envelope


def _sides_beyond(lo: NDArray, hi: NDArray, top: NDArray, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Whether a top's points ``top`` [k, 2] (x, y, m) reach ``top_margin`` beyond the footprint ``lo``, ``hi``
    [>= 2] of what stands on it, ``min_contacts`` points each, on its four sides [4]: -x, +x, -y, +y."""
    inside_y = (top[:, 1] >= lo[1]) & (top[:, 1] <= hi[1])
    inside_x = (top[:, 0] >= lo[0]) & (top[:, 0] <= hi[0])
    return np.array([
        (inside_y & (top[:, 0] < lo[0] - cfg.top_margin)).sum(),
        (inside_y & (top[:, 0] > hi[0] + cfg.top_margin)).sum(),
        (inside_x & (top[:, 1] < lo[1] - cfg.top_margin)).sum(),
        (inside_x & (top[:, 1] > hi[1] + cfg.top_margin)).sum(),
    ]) >= cfg.min_contacts  # fmt: skip


def _sides_at_wall(
    foot_lo: NDArray, foot_hi: NDArray, h: float, walls: list[dict], cfg: SegmentConfig
) -> NDArray[np.bool_]:
    """Whether each of the four sides [4] (-x, +x, -y, +y) of a footprint ``foot_lo``, ``foot_hi`` [>= 2] (m)
    on a top at height ``h`` (m) lies within ``wall_side_gap`` of a wall facing it, along the wall's seen
    stretch (``walls``: the wall planes of the structure, with ``normal``, ``offset`` and ``span``), and is
    at most ``wall_side_max_length`` long: no top is seen beyond a body there, nor could be. A longer side
    at a wall is a piece's own (a bed's pillows along its headboard)."""
    lo, hi = np.asarray(foot_lo[:2], float), np.asarray(foot_hi[:2], float)
    mid = 0.5 * (lo + hi)
    centres = np.array([[lo[0], mid[1], h], [hi[0], mid[1], h], [mid[0], lo[1], h], [mid[0], hi[1], h]])
    axes = np.array([0, 0, 1, 1])  # the axis each side faces along
    short = (hi - lo)[1 - axes] <= cfg.wall_side_max_length
    out = np.zeros(4, bool)
    for wall in walls:
        dist, along = _wall_coordinates(centres, wall)
        start, end = wall["span"]
        facing = np.abs(np.asarray(wall["normal"], float)[axes]) >= np.cos(np.radians(cfg.vertical_tolerance_deg))
        near = np.abs(dist) <= cfg.wall_side_gap
        out |= facing & near & (along >= start - cfg.wall_side_gap) & (along <= end + cfg.wall_side_gap)
    return out & short


def _held_by_top(
    lo: NDArray,
    hi: NDArray,
    top: NDArray,
    cfg: SegmentConfig,
    foot_lo: NDArray | None = None,
    foot_hi: NDArray | None = None,
    least: int | None = None,
    walled: NDArray[np.bool_] | None = None,
) -> bool:
    """Whether a part above a top, with bounds ``lo``, ``hi`` [3] (m), stands on it as a body of its own
    rather than being the piece's own back: the top's upward-facing points ``top`` [k, 2] (x, y) reach
    ``top_margin`` beyond its foot (the bounds ``foot_lo``, ``foot_hi`` [>= 2] of what it stands on, by
    default its own: a lamp's shade overhangs its base, and a small nightstand's top reaches past the base
    but not the shade) on ``top_sides`` of its four sides (``_sides_beyond``), or on both sides one way when
    it is ``body_min_thickness`` thick every way (a book stack flush with a desk's front edge, the desk seen
    beyond it left and right), and it is narrower than ``support_span_fraction`` of the top both ways (a
    chair's back, a headboard, a hutch spans its seat, bed or desk one way and stands at its edge). With
    ``walled`` [4] (``_sides_at_wall``), a side at a wall counts as one the top reaches beyond when the top
    is seen beyond the side across from it (a monitor at the back of a desk against the wall). A body
    spanning a narrow top one way only is its own when the top reaches beyond it on both sides the other
    way and it is ``body_min_thickness`` thick every way: a book stack as deep as the shelf it stands on,
    clear of the shelf's ends (a divider board across a desk is thinner). With ``least``, a body narrower
    than the top one way or both needs the top beyond its foot on that many sides only (a body stored
    under a board of its case, the shelf beyond it hidden)."""
    spans = hi[:2] - lo[:2] >= cfg.support_span_fraction * (top.max(axis=0) - top.min(axis=0))
    if spans.all():
        return False
    sides = _sides_beyond(lo if foot_lo is None else foot_lo, hi if foot_hi is None else foot_hi, top, cfg)
    if least is not None:
        return int(sides.sum()) >= least
    thick = float(np.min(hi - lo)) >= cfg.body_min_thickness
    if not spans.any():
        if walled is not None:
            sides = sides | (walled & sides[[1, 0, 3, 2]])  # a wall side counts where the top is seen across from it
        # the top beyond it on both sides one way holds it, as it holds a body spanning the top the other way
        either = bool(sides[:2].all() or sides[2:].all())
        return int(sides.sum()) >= cfg.top_sides or (either and thick)
    across = sides[2:] if spans[0] else sides[:2]  # the two sides of the way it does not span
    return bool(across.all()) and thick


def _rests_on(
    tops: NDArray, lo: NDArray, hi: NDArray, big_lo: NDArray, big_hi: NDArray, min_height: float, cfg: SegmentConfig
) -> bool:
    """Whether a region with bounds ``lo``, ``hi`` [3] (m) stands on an upward-facing surface of a larger one
    (``tops`` [k, 3]: its points whose normal is within 15 degrees of up; bounds ``big_lo``, ``big_hi``):
    some of those points lie under its footprint at its lowest height (within ``support_band``), the top is
    higher than ``min_height`` (m), the region is at least ``body_min_thickness`` thick every way (no board
    or panel), and it is narrower than the larger region both ways (a mattress spans its bed's frame and stays
    with it) or one way only with the top reaching ``top_margin`` beyond it on both sides the other way at
    its lowest height (``_sides_beyond``: a book stack as deep as its shelf, clear of the shelf's ends)."""
    if min(hi - lo) < cfg.body_min_thickness or lo[2] < min_height - cfg.support_band:
        return False  # a board or a panel of the larger one, not a body on it
    spans = hi[:2] - lo[:2] >= cfg.support_span_fraction * (big_hi[:2] - big_lo[:2])
    if spans.all():
        return False
    level = np.abs(tops[:, 2] - lo[2]) <= cfg.support_band
    if spans.any():  # as deep as its shelf: the shelf reaches beyond it on both sides the other way
        across = _sides_beyond(lo, hi, tops[level, :2], cfg)
        if not (across[2:] if spans[0] else across[:2]).all():
            return False
    under = np.all((tops[:, :2] >= lo[:2] - cfg.support_band) & (tops[:, :2] <= hi[:2] + cfg.support_band), axis=1)
    return int((under & level).sum()) >= cfg.min_contacts


def _under_board(case: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig, reach: float = np.inf) -> bool:
    """Whether ``min_contacts`` of a case's points ``case`` [k, 3] lie over the footprint of what stands in
    it (bounds ``lo``, ``hi`` [3], m), higher than its top by at most ``reach`` (m): a shelf board over a
    book stack."""
    over = np.all((case[:, :2] >= lo[:2]) & (case[:, :2] <= hi[:2]), axis=1)
    over &= (case[:, 2] > hi[2]) & (case[:, 2] <= hi[2] + reach)
    return int(over.sum()) >= cfg.min_contacts


def _board_share(case: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> float:
    """The share of the footprint of what stands in a case (bounds ``lo``, ``hi`` [3], m), in cells of twice
    ``superpoint_voxel``, that has a point of the case ``case`` [k, 3] over it, higher than its top by at
    most ``stored_board_reach`` (m): 1 under a shelf board."""
    cell = 2.0 * cfg.superpoint_voxel
    shape = np.maximum(np.ceil((hi[:2] - lo[:2]) / cell).astype(np.int64), 1)
    over = np.all((case[:, :2] >= lo[:2]) & (case[:, :2] <= hi[:2]), axis=1)
    over &= (case[:, 2] > hi[2]) & (case[:, 2] <= hi[2] + cfg.stored_board_reach)
    ij = np.minimum(((case[over, :2] - lo[:2]) / cell).astype(np.int64), shape - 1)
    return len(np.unique(ij[:, 0] * shape[1] + ij[:, 1])) / float(np.prod(shape))


def _stored_upright(big: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a region with bounds ``lo``, ``hi`` [3] (m) resting on a shelf of a larger one (its points
    ``big`` [k, 3]) is stored in it: taller than its smaller horizontal extent (books standing upright)
    and under a board of the larger one (``min_contacts`` of its points over the footprint, at most
    ``stored_cover_gap`` above the top). A book stack lies flat; a monitor or a lamp has no board over it."""
    if hi[2] - lo[2] < min(hi[:2] - lo[:2]):
        return False
    return _under_board(big, lo, hi, cfg, cfg.stored_cover_gap)


def _hangs_over(low: NDArray, top: NDArray, height: float, cfg: SegmentConfig) -> bool:
    """Whether ``min_contacts`` or more of the points ``top`` [k, 3] lower than ``height`` less
    ``support_band`` (m) lie over the footprint of the points ``low`` [m, 3], in cells of twice
    ``superpoint_voxel``: what hangs below a region's top over it, not beside it as foliage hangs beside its
    pot."""
    cell = 2.0 * cfg.superpoint_voxel
    below = top[top[:, 2] < height - cfg.support_band, :2]
    if len(below) < cfg.min_contacts:
        return False
    inside = np.isin(_cell_keys(below, cell), _cell_keys(low[:, :2], cell))
    return int(inside.sum()) >= cfg.min_contacts


def _cell_keys(xy: NDArray, cell: float) -> NDArray[np.int64]:
    """One integer per point of ``xy`` [k, 2] (m) naming its ``cell``-sized square of the plane (its column
    times 2^32 plus its row: distinct for any room)."""
    c = np.floor(xy / cell).astype(np.int64)
    return c[:, 0] * (1 << 32) + c[:, 1]
