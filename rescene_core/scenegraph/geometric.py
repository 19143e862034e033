"""The weight-free geometric relation backend: one frame's answer from what that frame shows.

For each visible instance it looks only at the points this frame sees (its masked depth, back-projected,
or its point cloud restricted to the pixels of its mask here) and at the other instances visible here:

1. its lowest visible points touch the floor plane -> rests-on floor;
2. it lies flat against a wall: the bulk of its points (median) within ``wall_flush_tol`` of a wall plane
   it stands in front of, spanning at most ``wall_max_depth`` off it -> mounts-on wall, whatever is
   beneath it (a picture hung just above a sofa back or a wall shelf nearly touches that upward face; a
   thing standing on furniture against a wall keeps its bulk further out); unless it is compact
   (``compact_on_a_wall``: a jar at the back of a counter), which hangs on the wall only when rule 3
   finds nothing beneath holding it;
3. a visible instance that can hold it from below (``geom.holds_from_below``: judged by its top surface
   around the child, not its lowest visible point) has upward-facing surface points from ``support_gap``
   below to ``support_tol`` above the child's bottom, under the child's footprint -> rests-on that
   instance (largest footprint overlap); an instance whose top keeps away from the wall the child's back is
   at (``bridges_to_wall``: a wall shelf just above a monitor) does not hold it, and a child that only such
   instances would hold -> mounts-on wall;
4. it is a large horizontal top at counter height with nothing seen below (``geom.seen_only_from_above``)
   -> rests-on floor (a counter or an island whose base is out of view);
5. its lower outline is hidden (behind a nearer instance or the image border) and it is not a flat thing
   on a wall (spanning at most ``wall_max_depth`` off the wall) -> rests-on floor (its base is out of
   view, not absent);
6. its back is within ``wall_tol`` of a wall plane it stands in front of -> mounts-on wall;
7. otherwise the highest visible instance beneath it that can hold it from below, its top under the
   child at most ``support_gap`` below the child's bottom (rests-on is contact), else the nearer of floor
   and wall.

Occlusion and partial views make frames disagree, as a VLM's answers do; fusion reconciles them.
It answers in the prompt's JSON format and does no A/B re-ranking.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from rescene_core.config import SceneGraphConfig
from rescene_core.records import Relation, Root
from rescene_core.scenegraph.backend import Query
from rescene_core.scenegraph.geom import (
    SPAN_QUANTILE,
    floor_only_shell,
    heights,
    holds_from_below,
    lower_surface,
    near_footprint,
    nearest_wall,
    seen_only_from_above,
    upper_surface,
    upward_mask,
    wall_back,
    wall_flush,
)
from rescene_core.scenegraph.prompt import answer_json
from rescene_core.scenegraph.view import visible_points

OCCLUSION_DEPTH_MARGIN = 0.02
"""A pixel below an instance hides its base when it shows something nearer by more than this (m)."""
OCCLUSION_ROWS = 2
"""How many pixels below an instance's lowest mask pixel (per image column) are inspected."""
COMPACT_ASPECT = 2.0
"""A thing flat against a wall whose bulk spans less than this many times its depth off the wall, along the
wall and in height, is compact (``compact_on_a_wall``): it hangs on the wall only when nothing beneath it
holds it. On the egocentric kitchens jars and bowls standing at the back of a counter measure 0.7-1.5 per
frame, and a spice jar 2.4-2.6; on the standard and cluttered scenes the things hung on walls 2.5 (a wall
clock) and more."""


SMALL_ON_A_WALL = 0.12
"""A thing flat against a wall whose bulk spans less than this (m) along the wall and in height is compact
too (``compact_on_a_wall``) whatever its aspect: a spice jar (under 10 cm, aspect 2.4-2.6 per frame) at the
back of a counter stands on the counter. The smallest things hung on walls of the synthetic scenes span more
(a wall clock 0.24-0.36 m across, its bulk about 0.16 m or more; pictures 0.3 m and more)."""
WALL_BRIDGE = 0.08
"""A child whose back is at a wall (``wall_back`` within ``wall_tol``) while the upward face of a thing under
it keeps more than this (m, its BRIDGE_QUANTILE quantile) further from that wall than the child's back spans
the gap between the two: it is held by the wall, not by the thing (a wall shelf 2 cm above a monitor: the
shelf's back 2-3 cm from the wall, the monitor's top 16-18 cm). A jar at the back of a counter has the
counter's top reaching the wall beside it."""
BRIDGE_QUANTILE = 0.25
"""The quantile of the support face's distances to the wall that says how near the wall it reaches: a lower
one reads the few points bled from the wall or the child at the face's edge (10% of a monitor's top points
lie within 3 cm of the wall behind it in some views)."""


def bridges_to_wall(child: np.ndarray, support: np.ndarray, shell) -> bool:
    """Whether a child (points [n, 3]) with its back at a wall spans the gap between a support's upward face
    (its points [m, 3] at the child's bottom height around the child) and that wall (WALL_BRIDGE)."""
    if len(support) < 3 or not len(child):
        return False
    wall, _ = nearest_wall(child, shell)
    if wall is None:
        return False
    back = wall_back(child, wall)
    face = float(np.quantile(wall.plane.signed_distance(support), BRIDGE_QUANTILE))
    return face - back > WALL_BRIDGE


def bottom_occluded(view, instance: int) -> bool:
    """Whether most of the instance's lower outline is hidden in this frame: the pixel just below it shows
    a nearer instance or lies outside the image, or the instance reaches the image's left or right edge
    (it goes on outside the frame, and so may its base: a floor lamp whose head alone is in the corner of
    the picture). Needs depth (False without)."""
    if view.depth is None:
        return False
    m = view.mask == instance
    cols = np.flatnonzero(m.any(axis=0))
    if not len(cols):
        return False
    if cols[0] == 0 or cols[-1] == m.shape[1] - 1:
        return True
    height = m.shape[0]
    lowest = height - 1 - np.argmax(m[::-1, cols], axis=0)
    below = lowest + OCCLUSION_ROWS
    out = below >= height
    inside = ~out
    rows, cc = below[inside], cols[inside]
    other = view.mask[rows, cc]
    nearer = view.depth[rows, cc] < view.depth[lowest[inside], cc] - OCCLUSION_DEPTH_MARGIN
    hidden = (other != instance) & (other > 0) & nearer & (view.depth[rows, cc] > 0)
    return bool((out.sum() + hidden.sum()) > 0.5 * len(cols))


def flat_on_a_wall(points, shell, cfg) -> bool:
    """Whether the points [n, 3] lie flat against a wall: their bulk (median) within ``wall_flush_tol`` of
    its plane and at most ``wall_max_depth`` deep (a picture, a mirror, a TV)."""
    flush, flush_d, flush_span = wall_flush(points, shell)
    return flush is not None and flush_d <= cfg.wall_flush_tol and flush_span <= cfg.wall_max_depth


def compact_on_a_wall(points, shell) -> bool:
    """Whether the points [n, 3], flat against a wall (``flat_on_a_wall``), are compact: the bulk of them
    (the SPAN_QUANTILE to 1 - SPAN_QUANTILE range) spans less than COMPACT_ASPECT times its depth off the
    wall both along the wall and in height, or less than SMALL_ON_A_WALL. A jar or a bowl at the back of a
    counter is as deep as it is wide, a spice jar smaller than anything hung on a wall; pictures, mirrors,
    TVs, clocks and shelves are at least 2.5 times wider or taller than deep."""
    wall, _, span = wall_flush(points, shell)
    if wall is None:
        return False
    pts = np.asarray(points, dtype=np.float64)
    n = np.asarray(wall.plane.normal, dtype=np.float64)
    along = np.array([-n[1], n[0], 0.0]) / max(float(np.hypot(n[0], n[1])), 1e-9)
    extents = [np.subtract(*np.quantile(v, [1.0 - SPAN_QUANTILE, SPAN_QUANTILE])) for v in (pts @ along, pts[:, 2])]
    return bool(max(extents) < COMPACT_ASPECT * span or max(extents) < SMALL_ON_A_WALL)


class GeometricPredictor:
    """Per-frame relations from the frame's visible geometry (no model weights)."""

    backend = "geometric"
    model = "geometric-v1"
    supports_ab = False

    def __init__(self, config: SceneGraphConfig):
        self.config = config

    def answer(self, query: Query) -> str:
        if query.kind != "relations":
            raise ValueError("the geometric backend answers only the per-frame relation prompt")
        cfg = self.config.geometric
        view, capture = query.view, query.capture
        shell = query.shell if query.shell is not None else floor_only_shell(capture)
        pts = {v.display: visible_points(capture, view, int(v.instance)) for v in view.visible}
        h = {d: heights(shell, p) for d, p in pts.items()}
        bottom = {d: lower_surface(h[d]) for d in pts}
        up = {d: upward_mask(p, shell, cfg.normal_neighbours, cfg.upward_normal_deg) for d, p in pts.items()}
        occluded = {v.display: bottom_occluded(view, int(v.instance)) for v in view.visible}
        entries = []
        for v in view.visible:
            d = v.display
            relation, parent = self._decide(d, pts, h, up, bottom, occluded, shell, cfg)
            entries.append({"id": d, "category": v.label, "relation": relation, "parent": parent})
        return answer_json(entries)

    @staticmethod
    def _decide(d, pts, h, up, bottom, occluded, shell, cfg) -> tuple[str, int | str]:
        p, b = pts[d], bottom[d]
        if len(p) < cfg.min_points:
            return Relation.RESTS_ON.value, Root.FLOOR.value
        if b <= cfg.floor_contact_tol:
            return Relation.RESTS_ON.value, Root.FLOOR.value
        flat = flat_on_a_wall(p, shell, cfg)
        if flat and not compact_on_a_wall(p, shell):
            return Relation.MOUNTS_ON.value, Root.WALL.value
        xy = p[:, :2]
        wall, wall_d = nearest_wall(p, shell)
        against = wall is not None and wall_back(p, wall) <= cfg.wall_tol
        best, best_key = None, None
        below = []
        bridged = False
        for q, pq in pts.items():
            if q == d or len(pq) < cfg.min_points:
                continue
            if flat_on_a_wall(pq, shell, cfg):
                continue  # a picture or a mirror hangs flat on its wall and carries nothing (a shelf just above it)
            hq = h[q]
            around = near_footprint(pq, xy, cfg.support_radius)
            # judged by its top surface around the child, not its lowest visible point (an island seen only
            # from above has its lowest visible point at its top, at the child's bottom)
            if not holds_from_below(pq, hq, bottom[q], around, xy, b, cfg.support_tol):
                continue
            # an upward-facing surface of q at the child's bottom height (a bed's side beside a nightstand,
            # or the neighbouring book's side, is at that height too, but faces sideways)
            band = (hq >= b - cfg.support_gap) & (hq <= b + cfg.support_tol) & up[q]
            if against and bridges_to_wall(p, pq[band & around], shell):
                bridged = True  # the child spans the gap from q's top to the wall it hangs on
                continue
            # its highest points under the child, below the child's bottom: more than support_gap lower, the
            # child does not rest on it (a wall cabinet above a cup)
            under = around & (hq < b + cfg.support_tol)
            if under.any() and upper_surface(hq[under]) >= b - cfg.support_gap:
                below.append((upper_surface(hq[under]), q))
            surface = pq[band][:, :2]
            if len(surface) < 3:
                continue
            dist = cKDTree(surface).query(xy, distance_upper_bound=cfg.support_radius)[0]
            overlap = float(np.isfinite(dist).mean())
            key = (overlap, -abs(float(np.median(hq[band])) - b))
            if overlap >= cfg.min_support_overlap and (best_key is None or key > best_key):
                best, best_key = q, key
        if best is not None:
            return Relation.RESTS_ON.value, int(best)
        if flat or bridged:
            # compact, against a wall, nothing beneath holds it; or it spans the gap from what is under it to
            # the wall
            return Relation.MOUNTS_ON.value, Root.WALL.value
        if seen_only_from_above(h[d], xy):
            return Relation.RESTS_ON.value, Root.FLOOR.value  # a counter or an island whose base is out of view
        flat_on_wall = False
        if wall is not None and wall_d <= cfg.wall_tol:
            span = wall.plane.signed_distance(p)
            lo, hi = np.quantile(span, [SPAN_QUANTILE, 1.0 - SPAN_QUANTILE])
            flat_on_wall = hi - lo <= cfg.wall_max_depth
        if occluded.get(d, False) and not flat_on_wall:
            return Relation.RESTS_ON.value, Root.FLOOR.value  # its base is hidden, not absent
        if wall is not None and wall_d <= cfg.wall_tol:
            return Relation.MOUNTS_ON.value, Root.WALL.value
        if below:
            return Relation.RESTS_ON.value, int(max(below)[1])
        if wall is not None and wall_d < b:
            return Relation.MOUNTS_ON.value, Root.WALL.value
        return Relation.RESTS_ON.value, Root.FLOOR.value
