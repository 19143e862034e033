"""Which regions are objects: too small, too large, upright sheets as tall as a wall and slivers of
the structure are dropped; regions flush with a wall are kept as pictures, mirrors, clocks, TVs."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.colour import _in_shadow
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import ScanPoints, points_by_region
from rescene_core.segment.geometric.structure import (
    _faces_wall,
    _is_wall_piece,
    _mostly_structure,
    _nearest_wall,
    _structure_distance,
)
from rescene_core.segment.geometric.walls import wall_colours
from rescene_core.segment.superpoints import SuperpointGraph


def _rim_step(g: SuperpointGraph, rim: NDArray[np.bool_]) -> float:
    """Mean colour step (RGB distance / sqrt 3) over the graph edges of the contacts ``rim`` [p]."""
    return float((g.step[rim] * g.contacts[rim]).sum() / max(int(g.contacts[rim].sum()), 1))


def _filter_regions(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which_wall: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
    flush_by_masks: bool = False,
) -> tuple[NDArray[np.int64], dict[str, int]]:
    """Regions renumbered 1..k after dropping the too small, the too large (leftovers of the room), slivers
    of the structure (a region within ``structure_band`` of the floor, walls and ceiling and thinner than
    ``sliver_thickness`` across them: the rounded corner where a wall meets the ceiling) and wall patches
    that are not flush objects (touching the floor or ceiling, as a door does, or of the wall's colour, or
    outlined only as a shadow is)."""
    g = sp.graph
    point_region = region[g.label]
    out = np.zeros_like(region)
    counts = {"too_small": 0, "too_large": 0, "joined_structure": 0, "flush_objects": 0, "wall_patches": 0}
    ceiling = [float(p["height"]) for p in planes if p["kind"] == "ceiling"]
    top = ceiling[0] if ceiling else np.inf
    normals = {int(p["id"]): (np.asarray(p["normal"]), float(p["offset"])) for p in planes if p["kind"] == "wall"}
    paint = wall_colours(sp)
    nxt = 1
    order, bounds = points_by_region(point_region, int(region.max()) + 1)
    for r in range(1, int(region.max()) + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) == 0:
            continue
        p = sp.points[idx]
        ext = float(np.ptp(p, axis=0).max())
        if len(idx) < cfg.min_segment_points or ext < cfg.min_segment_extent:
            counts["too_small"] += 1
            continue
        if ext > cfg.max_segment_extent:
            counts["too_large"] += 1
            continue
        walls, n_on = np.unique(sp.wall[idx], return_counts=True)
        wall = int(walls[np.argmax(n_on)])
        hangs = p[:, 2].min() >= cfg.flush_min_height and p[:, 2].max() <= top - cfg.flush_ceiling_gap
        # the colour step right across its outline, against the wall around it: a picture's edge is
        # sharp, a shading gradient on the paint is not
        inside = region[g.pairs[:, 0]] == r
        outside = region[g.pairs[:, 1]] == r
        rim_wall = np.where(inside, which_wall[g.pairs[:, 1]], which_wall[g.pairs[:, 0]])
        if wall > 0 and n_on.max() >= 0.5 * len(idx):
            n, d = normals[wall]
            proud = float(np.median(p @ n + d))
            edge = _rim_step(g, (inside ^ outside) & (rim_wall == wall))
            # with masks the region is already a consensus of views: hanging clear is enough
            outline = edge >= cfg.flush_edge_step and not _in_shadow(sp.colours[idx], paint.get(wall), cfg)
            apart = flush_by_masks or outline or proud >= cfg.flush_offset
            if hangs and ext <= cfg.flush_max_extent and apart:
                counts["flush_objects"] += 1
                out[region == r] = nxt
                nxt += 1
            else:
                counts["wall_patches"] += 1
            continue
        if _is_wall_piece(p, cfg):
            counts["joined_structure"] += 1
            continue
        dist = _structure_distance(p, planes)
        sliver = _mostly_structure(dist, cfg)
        # thinner than ``sliver_thickness`` across the plane, or as tall as a wall (a stretch of wall whose
        # fused surface wanders a few centimetres about the plane: no furniture lies along a wall that tall)
        sliver &= bool(np.percentile(dist, 95) < cfg.sliver_thickness) or bool(np.ptp(p[:, 2]) >= cfg.wall_piece_height)
        if sliver and hangs:
            # a thin region hanging on a wall off its plane (a wall clock, a mirror's frame): an object when
            # the masks see it apart, when its outline steps in colour, or when it stands proud of the wall
            # and faces the room as the wall does (a stretch of the wall whose fused normals stray off the
            # plane's, and so stayed off it, lies in it and faces every way)
            edge = _rim_step(g, (inside ^ outside) & (rim_wall > 0))
            near = paint.get(_nearest_wall(p, planes))
            outline = edge >= cfg.flush_edge_step and not _in_shadow(sp.colours[idx], near, cfg)
            proud = float(np.median(dist)) >= cfg.flush_offset and _faces_wall(p, sp.normals[idx], planes, cfg)
            if flush_by_masks or outline or proud:
                sliver = False
        if sliver:
            counts["joined_structure"] += 1
            continue
        out[region == r] = nxt
        nxt += 1
    counts["kept"] = nxt - 1
    return out, counts
