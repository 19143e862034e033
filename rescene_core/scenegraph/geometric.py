"""The weight-free geometric relation backend: one frame's answer from what that frame shows.

For each visible instance it looks only at the points this frame sees (its masked depth, back-projected,
or its point cloud restricted to the pixels of its mask here) and at the other instances visible here:

1. its lowest visible points touch the floor plane -> rests-on floor;
2. a visible instance that starts lower has surface points at the child's bottom height, under the
   child's footprint -> rests-on that instance (largest footprint overlap);
3. its back is within ``wall_tol`` of a wall plane it stands in front of -> mounts-on wall;
4. otherwise the nearer of floor and wall, or the highest visible instance beneath it.

Occlusion and partial views make frames disagree, as a VLM's answers do; fusion reconciles them.
It answers in the prompt's JSON format and does no A/B re-ranking.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from rescene_core.config import SceneGraphConfig
from rescene_core.records import Relation, Root
from rescene_core.scenegraph.backend import Query
from rescene_core.scenegraph.geom import floor_only_shell, heights, lower_surface, nearest_wall, upper_surface
from rescene_core.scenegraph.prompt import answer_json
from rescene_core.scenegraph.view import visible_points


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
        cfg = self.config
        view, capture = query.view, query.capture
        shell = query.shell if query.shell is not None else floor_only_shell(capture)
        pts = {v.display: visible_points(capture, view, int(v.instance)) for v in view.visible}
        h = {d: heights(shell, p) for d, p in pts.items()}
        bottom = {d: lower_surface(h[d]) for d in pts}
        entries = []
        for v in view.visible:
            d = v.display
            relation, parent = self._decide(d, pts, h, bottom, shell, cfg)
            entries.append({"id": d, "category": v.label, "relation": relation, "parent": parent})
        return answer_json(entries)

    @staticmethod
    def _decide(d, pts, h, bottom, shell, cfg) -> tuple[str, int | str]:
        p, b = pts[d], bottom[d]
        if len(p) < cfg.min_points:
            return Relation.RESTS_ON.value, Root.FLOOR.value
        if b <= cfg.floor_contact_tol:
            return Relation.RESTS_ON.value, Root.FLOOR.value
        xy = p[:, :2]
        best, best_key = None, None
        below = []
        for q, pq in pts.items():
            if q == d or len(pq) < cfg.min_points or not bottom[q] < b - cfg.support_tol:
                continue
            hq = h[q]
            surface = pq[np.abs(hq - b) <= cfg.support_tol][:, :2]
            under = pq[hq < b + cfg.support_tol][:, :2]
            if len(under):
                near = cKDTree(under).query(xy, distance_upper_bound=cfg.support_radius)[0]
                if np.isfinite(near).mean() > 0:
                    below.append((upper_surface(hq[hq < b + cfg.support_tol]), q))
            if len(surface) < 3:
                continue
            dist = cKDTree(surface).query(xy, distance_upper_bound=cfg.support_radius)[0]
            overlap = float(np.isfinite(dist).mean())
            key = (overlap, -abs(float(np.median(hq[np.abs(hq - b) <= cfg.support_tol])) - b))
            if overlap >= cfg.min_support_overlap and (best_key is None or key > best_key):
                best, best_key = q, key
        if best is not None:
            return Relation.RESTS_ON.value, int(best)
        wall, wall_d = nearest_wall(p, shell)
        if wall is not None and wall_d <= cfg.wall_tol:
            return Relation.MOUNTS_ON.value, Root.WALL.value
        if below:
            return Relation.RESTS_ON.value, int(max(below)[1])
        if wall is not None and wall_d < b:
            return Relation.MOUNTS_ON.value, Root.WALL.value
        return Relation.RESTS_ON.value, Root.FLOOR.value
