"""Region merging (step 4 of the label-free front end): superpoints join over their contacts, then the
rules of the other modules of this package run in order."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.cases import _join_stored_rows, _rejoin_enclosed
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.filter import _filter_regions
from rescene_core.segment.geometric.joins import _absorb_small, _attach_backs, _attach_legs, _join_bedding, _join_stems
from rescene_core.segment.geometric.points import ScanPoints, _components
from rescene_core.segment.geometric.stacks import split_stacked
from rescene_core.segment.geometric.structure import _structure_distance
from rescene_core.segment.geometric.tops import split_bodies_on_tops
from rescene_core.segment.geometric.walls import (
    _join_brackets,
    part_from_wall_stretch,
    take_off_wall_paint,
    wall_superpoints,
)
from rescene_core.segment.superpoints import SuperpointGraph


def _support_cut(
    g: SuperpointGraph, a: NDArray[np.int64], b: NDArray[np.int64], cfg: SegmentConfig
) -> NDArray[np.bool_]:
    """Whether superpoint b stands on a (a is a horizontal top above ``support_min_height`` and b rises
    from its height) and is narrower than it both ways (what spans the top is the piece's own back)."""
    top_z = g.centroid[a, 2]
    is_top = (g.up[a] >= cfg.support_up_share) & (top_z >= cfg.support_min_height)
    rises = (g.lo[b, 2] >= top_z - cfg.support_band) & (g.centroid[b, 2] > top_z + cfg.support_band)
    span_top = g.hi[a, :2] - g.lo[a, :2]
    span_b = g.hi[b, :2] - g.lo[b, :2]
    spans = (span_b >= cfg.support_span_fraction * span_top).any(axis=1)
    return is_top & rises & ~spans


def merge_superpoints(
    sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], dict[str, Any]]:
    """The scan points (their superpoints split where a body stands on a top: ``split_bodies_on_tops``),
    the object region [s] of each superpoint (0: none) and its wall [s] (0: none), from geometry and colour
    alone (see the module docstring), with counts for the report."""
    g = sp.graph
    n = g.size
    which, flush = wall_superpoints(sp, planes, cfg)
    free = (which == 0) | flush
    a, b = g.pairs[:, 0], g.pairs[:, 1]
    crease = g.concave / np.maximum(g.contacts, 1) >= cfg.concave_fraction
    colour = np.linalg.norm(g.colour[a] - g.colour[b], axis=1) / np.sqrt(3.0)
    support = _support_cut(g, a, b, cfg) | _support_cut(g, b, a, cfg)
    join = free[a] & free[b] & (g.contacts >= cfg.min_contacts)
    cut_crease = join & crease & (colour >= cfg.concave_colour_step)
    cut_colour = join & (colour >= cfg.colour_cut)
    cut_support = join & support
    join &= ~(cut_crease | cut_colour | cut_support)
    comp = _components(n, g.pairs, join)
    region = np.where(free, comp + 1, 0)
    stats = {
        "superpoints": int(n),
        "contacts": int(len(g.pairs)),
        "cut_crease": int(cut_crease.sum()),
        "cut_colour": int(cut_colour.sum()),
        "cut_support": int(cut_support.sum()),
        "flush_superpoints": int(flush.sum()),
    }
    # flush pieces on one wall parted by colour join when one lies within the other's bounds: a picture's
    # canvas in its frame, a mirror's glass in its frame, a clock's face in its rim (a clock hung just above
    # a picture lies beside it and stays apart)
    hung = flush[a] & flush[b] & (which[a] == which[b]) & (g.contacts >= cfg.min_contacts) & ~join
    region, stats["rejoined_flush"] = _rejoin_enclosed(sp, region, hung, np.zeros(n, bool), cfg, by_extent=True)
    region = _absorb_small(g, region, cfg)
    region, stats["legs_attached"] = _attach_legs(sp, region, cfg)
    region, stats["backs_attached"] = _attach_backs(sp, region, planes, cfg)
    near_structure = _structure_distance(g.centroid, planes) < cfg.structure_band
    region, stats["rejoined_enclosed"] = _rejoin_enclosed(
        sp, region, cut_crease & ~cut_colour & ~cut_support, near_structure, cfg
    )
    region, stats["stems_joined"] = _join_stems(sp, region, cfg, planes)
    region, stats["brackets_joined"] = _join_brackets(sp, region, cfg, planes)
    region, stats["rows_joined"] = _join_stored_rows(sp, region, cfg)
    sp, region, which, stats["parted_from_wall"] = part_from_wall_stretch(sp, region, which, planes, cfg)
    split_from = int(region.max(initial=0)) + 1
    sp, region, which, stats["split_from_tops"] = split_bodies_on_tops(sp, region, which, cfg, planes)
    sp, region, which, stats["stacks_split"] = split_stacked(sp, region, which, cfg)
    # a lamp's base that ``_absorb_small`` gave to its nightstand came back off the top as a body of its own:
    # now under its shade as a stem is
    region, stats["stems_rejoined"] = _join_stems(sp, region, cfg, planes, split_from)
    region, stats["bedding_joined"] = _join_bedding(sp, region, cfg)
    sp, region, which, stats["wall_points_taken_off"] = take_off_wall_paint(sp, region, which, planes, cfg)
    region, drop = _filter_regions(sp, region, which, planes, cfg)
    stats.update(drop)
    return sp, region, which, stats
