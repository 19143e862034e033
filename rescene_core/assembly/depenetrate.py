"""Depenetration: small contact-reverse displacements for colliding non-related pairs (paper Table A, last row).

Each iteration finds the colliding pairs (rtree + fcl, pairs where one object is an ancestor of the other
excluded) and, for each pair, the minimum translation vector that separates the two convex footprints
(separating-axis test, plus ``contact_gap`` of clearance). The pair shares it inversely to footprint area,
so a lamp yields to a bed. Per iteration an object moves at most ``depenetration_step`` m; a wall-mounted
object moves only along its wall, at most ``wall_tangent_step`` m. A move that would take the footprint
out of the room is cut back into it. Objects move with their descendants. At most
``depenetration_iterations`` iterations; stops early when nothing collides.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.evidence import containment_footprint
from rescene_core.assembly.refine import containment_region, is_outside
from rescene_core.assembly.room import fit_translation
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.records import InstanceId


def separating_vector(a: Polygon, b: Polygon) -> NDArray[np.float64]:
    """Minimum translation (dx, dy) of convex ``a`` that ends its overlap with convex ``b`` (SAT)."""
    best_len, best_axis = np.inf, np.zeros(2)
    pa = np.asarray(a.exterior.coords)[:-1]
    pb = np.asarray(b.exterior.coords)[:-1]
    for poly in (pa, pb):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
        lengths = np.linalg.norm(normals, axis=1)
        normals = normals[lengths > 1e-12] / lengths[lengths > 1e-12, None]
        proj_a, proj_b = pa @ normals.T, pb @ normals.T
        push_pos = proj_b.max(axis=0) - proj_a.min(axis=0)  # move a along +n
        push_neg = proj_a.max(axis=0) - proj_b.min(axis=0)  # move a along -n
        for k in range(len(normals)):
            for amount, sign in ((push_pos[k], 1.0), (push_neg[k], -1.0)):
                if 0 <= amount < best_len:
                    best_len, best_axis = amount, sign * normals[k]
    if not np.isfinite(best_len):
        return np.zeros(2)
    return best_axis * best_len


def depenetrate(state: LayoutState, world: CollisionWorld, stage: str = "depenetration") -> int:
    """Run the depenetration iterations in place; returns the number of colliding pairs left."""
    cfg = state.config
    forest = state.forest
    pairs = []
    for iteration in range(cfg.depenetration_iterations):
        pairs = world.colliding_pairs({i: state.pose(i) for i in state.objects}, skip=forest.related)
        if not pairs:
            return 0
        moves: dict[InstanceId, NDArray[np.float64]] = defaultdict(lambda: np.zeros(3))
        partners: dict[InstanceId, list[int]] = defaultdict(list)
        for a, b in pairs:
            fa, fb = state.footprint(a), state.footprint(b)
            mtv = separating_vector(fa, fb)
            norm = np.linalg.norm(mtv)
            if norm < 1e-9:  # footprints only touch, yet meshes cross: push along the centre offset
                d = (state.centre(a) - state.centre(b))[:2]
                mtv = d / np.linalg.norm(d) * 1e-3 if np.linalg.norm(d) > 1e-9 else np.array([1e-3, 0.0])
                norm = 1e-3
            total = mtv * (norm + cfg.contact_gap) / norm
            wa = fb.area / max(fa.area + fb.area, 1e-12)
            if a in state.unfit or b in state.unfit:
                wa = 0.0 if a in state.unfit else 1.0
            moves[a][:2] += wa * total
            moves[b][:2] -= (1.0 - wa) * total
            partners[a].append(int(b))
            partners[b].append(int(a))
        for i, move in moves.items():
            if i in state.unfit:
                continue
            if i in state.wall_of:
                wall = state.room.wall(state.wall_of[i])
                move = (move @ wall.tangent) * wall.tangent if wall is not None else move
                cap = cfg.wall_tangent_step
            else:
                cap = cfg.depenetration_step
            length = np.linalg.norm(move)
            if length < 1e-9:
                continue
            if length > cap:
                move = move * cap / length
            was_outside = is_outside(state, i)
            state.move(
                i, translation(move), stage, "contact-reverse displacement", iteration=iteration, partners=partners[i]
            )
            if not was_outside and is_outside(state, i):
                shift = fit_translation(containment_footprint(state, i), containment_region(state, i))
                if shift is not None:
                    state.move(i, translation([shift[0], shift[1], 0.0]), stage, "keep inside after push")
    pairs = world.colliding_pairs({i: state.pose(i) for i in state.objects}, skip=forest.related)
    return len(pairs)
