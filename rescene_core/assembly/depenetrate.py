"""Depenetration: small contact-reverse displacements for colliding non-related pairs (paper Table A, last row).

Each iteration finds the colliding pairs (rtree + fcl, pairs where one object is an ancestor of the other
excluded). Each side of a pair is a *mover*: the object itself, or, for an object resting on another, the
top of its support chain (the object on the floor or the wall that carries it), so a lamp pushed by a bed
takes its nightstand along instead of sliding off it (two objects carried by the same mover move
themselves). A mover's separating vector is the minimum translation that ends the overlap of the two
convex outlines (separating-axis test, plus ``contact_gap`` of clearance): footprints on the floor plane
for a floor mover; outlines projected on the wall plane (along the wall and up) for a wall-mounted mover,
which may only slide in its wall's plane, so a picture under a shelf moves down rather than nowhere. The
pair shares the separation inversely to footprint area, so a lamp yields to a bed. Per iteration a mover
moves at most ``depenetration_step`` m, a wall-mounted one at most ``wall_tangent_step`` m. A move that
would take the footprint out of the room is cut back into it; a mover that a wall stops that way (less than
half of its push left) is blocked, and from then on its partners take the whole separation, so a
nightstand jammed between a bed and a wall makes the bed move instead of shuttling in place. Movers take
their descendants along. A generated mover with observed points takes no more of a push than keeps its
mesh box's surface on its points within ``depenetration_max_fit_drop`` of its registered share
(``evidence.surface_fit``)
(``bounded_push``); held there, it is blocked like a mover a wall stopped, and a pair whose objects are both
held keeps its overlap (a completion error, not a placement one). An object resting on another object
whose lowest point lies at most ``LIFT_MAX`` below the top of a neighbour it collides with, its own top
above that one, is lifted onto that top instead (``lift_onto``): a cutting board on one counter reaching
2 mm into the next counter's top lies on both; a sideways push ends that overlap only by moving a whole
counter the board's overlap (23 cm) along its row. At most ``depenetration_iterations`` iterations;
stops early when nothing collides.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import MultiPoint, Polygon

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.evidence import containment_footprint, surface_fit
from rescene_core.assembly.refine import containment_region, is_outside
from rescene_core.assembly.room import fit_translation
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.records import InstanceId


def _mover(state: LayoutState, i: InstanceId) -> InstanceId:
    """The object a push on ``i`` moves: the top of its chain of ``rests-on`` object edges."""
    while (support := state.forest.support_of(i)) is not None:
        i = support
    return i


def _wall_outline(verts: NDArray, tangent: NDArray, up: NDArray) -> Polygon | None:
    """Convex outline of world vertices [v, 3] on a wall plane, in (along the wall, up) coordinates (m)."""
    hull = MultiPoint(np.stack([verts @ tangent, verts @ up], axis=1)).convex_hull
    return hull if isinstance(hull, Polygon) else None


LIFT_MAX = 0.01
"""Deepest (m) an object resting on another may reach below a colliding neighbour's top and be lifted onto it
rather than pushed sideways: registration and fusion put neighbouring tops a few millimetres apart."""
LIFT_CLEARANCE = 1e-3
"""Gap (m) a lifted object keeps above the neighbour's top, so the pair no longer collides."""


def lift_onto(state: LayoutState, a: InstanceId, b: InstanceId) -> tuple[InstanceId, float] | None:
    """(object, lift in m) when one of the colliding pair rests on an object and reaches at most ``LIFT_MAX``
    below the other's top with its own top above it (the lift puts it ``LIFT_CLEARANCE`` above that top);
    None otherwise (the pair is pushed apart sideways)."""
    up = state.room.up
    heights = {i: state.vertices(i) @ up for i in (a, b)}
    for upper, lower in ((a, b), (b, a)):
        if state.forest.support_of(upper) is None:
            continue
        below = float(heights[lower].max() - heights[upper].min())
        if 0.0 < below <= LIFT_MAX and heights[upper].max() > heights[lower].max():
            return upper, below + LIFT_CLEARANCE
    return None


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
    blocked: set[InstanceId] = set()  # movers a wall stopped: their partners take the whole separation
    for iteration in range(cfg.depenetration_iterations):
        pairs = world.colliding_pairs({i: state.pose(i) for i in state.objects}, skip=forest.related)
        if not pairs:
            return 0
        moves: dict[InstanceId, NDArray[np.float64]] = defaultdict(lambda: np.zeros(3))
        partners: dict[InstanceId, list[int]] = defaultdict(list)
        lifts: dict[InstanceId, tuple[float, int]] = {}
        for a, b in pairs:
            lift = lift_onto(state, a, b)
            if lift is not None:
                upper, height = lift
                if height > lifts.get(upper, (0.0, -1))[0]:
                    lifts[upper] = (height, int(b if upper == a else a))
                continue
            ma, mb = _mover(state, a), _mover(state, b)
            if ma == mb:  # carried by the same object: they move on it themselves
                ma, mb = a, b
            fa, fb = state.footprint(a), state.footprint(b)
            wa = fb.area / max(fa.area + fb.area, 1e-12)
            if a in state.unfit or b in state.unfit:
                wa = 0.0 if a in state.unfit else 1.0
            elif (ma in blocked) != (mb in blocked):
                wa = 0.0 if ma in blocked else 1.0
            for mover, this, other, share in ((ma, a, b, wa), (mb, b, a, 1.0 - wa)):
                if share > 0.0:
                    moves[mover] += share * _separation(state, mover, this, other)
                    partners[mover].append(int(other))
        for i, (height, onto) in lifts.items():
            state.move(
                i, translation(height * state.room.up), stage, "lift onto neighbour's top", bounded=False, onto=onto
            )
        for i, move in moves.items():
            if i in state.unfit:
                continue
            cap = cfg.wall_tangent_step if i in state.wall_of else cfg.depenetration_step
            length = np.linalg.norm(move)
            if length < 1e-9:
                continue
            if length > cap:
                move = move * cap / length
            kept = bounded_push(state, i, move)
            if kept < 1.0:
                blocked.add(i)  # its points hold it: the partners take the separation from now on
                move = move * kept
                if kept <= 0.0:
                    state.log(i, stage, "held by its points", iteration=iteration, partners=partners[i])
                    continue
            was_outside = is_outside(state, i)
            state.move(
                i,
                translation(move),
                stage,
                "contact-reverse displacement",
                bounded=False,
                iteration=iteration,
                partners=partners[i],
            )
            if not was_outside and is_outside(state, i):
                shift = fit_translation(containment_footprint(state, i), containment_region(state, i))
                if shift is not None:
                    state.move(
                        i, translation([shift[0], shift[1], 0.0]), stage, "keep inside after push", bounded=False
                    )
                    if np.linalg.norm(move[:2] + shift) < 0.5 * np.linalg.norm(move[:2]):
                        blocked.add(i)
    pairs = world.colliding_pairs({i: state.pose(i) for i in state.objects}, skip=forest.related)
    return len(pairs)


PUSH_SEARCH_STEPS = 6
"""Bisection steps of the longest push an object's points allow (1/64 of the push)."""


def bounded_push(state: LayoutState, i: InstanceId, move: NDArray) -> float:
    """Fraction (0 to 1) of the world translation ``move`` [3] object i may take: 1 unless it is a generated
    asset whose points the push would leave behind (``depenetration_max_fit_drop``), else the longest
    fraction that keeps to the bound (0 when even the current pose is beyond it)."""
    bound = state.config.depenetration_max_fit_drop
    obj = state.objects[i]
    if bound is None or obj.exact_shape or obj.points is None or len(obj.points) == 0:
        return 1.0
    registered = surface_fit(obj, obj.world_from_asset) or 0.0
    floor = min(registered - bound, surface_fit(obj, state.pose(i)) or 0.0)

    def allowed(fraction: float) -> bool:
        return (surface_fit(obj, translation(fraction * move) @ state.pose(i)) or 0.0) >= floor

    if allowed(1.0):
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(PUSH_SEARCH_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if allowed(mid) else (lo, mid)
    return lo


def _separation(state: LayoutState, mover: InstanceId, this: InstanceId, other: InstanceId) -> NDArray[np.float64]:
    """World translation [3] (m) of ``mover`` that ends the overlap of ``this`` (``mover`` or one it carries)
    with ``other``: on the floor plane, or in the wall's plane for a wall-mounted mover (module docstring)."""
    cfg = state.config
    wall = state.room.wall(state.wall_of[mover]) if mover in state.wall_of else None
    if wall is not None:
        up = state.room.up
        pa = _wall_outline(state.vertices(this), wall.tangent, up)
        pb = _wall_outline(state.vertices(other), wall.tangent, up)
        if pa is not None and pb is not None:
            mtv = separating_vector(pa, pb)
            norm = float(np.linalg.norm(mtv))
            if norm > 1e-9:
                mtv = mtv * (norm + cfg.contact_gap) / norm
                return mtv[0] * wall.tangent + mtv[1] * up
        d = state.centre(this) - state.centre(other)
        along = np.array([d @ wall.tangent, d @ up])
        n = float(np.linalg.norm(along))
        along = along / n if n > 1e-9 else np.array([1.0, 0.0])
        return 1e-3 * (along[0] * wall.tangent + along[1] * up)
    fa, fb = state.footprint(this), state.footprint(other)
    mtv = separating_vector(fa, fb)
    norm = float(np.linalg.norm(mtv))
    if norm < 1e-9:  # footprints only touch, yet meshes cross: push along the centre offset
        d = (state.centre(this) - state.centre(other))[:2]
        mtv = d / np.linalg.norm(d) * 1e-3 if np.linalg.norm(d) > 1e-9 else np.array([1e-3, 0.0])
        norm = 1e-3
    total = mtv * (norm + cfg.contact_gap) / norm
    return np.array([total[0], total[1], 0.0])
