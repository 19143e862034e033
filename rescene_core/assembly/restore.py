"""Back toward the evidence: the last stage returns each generated object toward where the capture saw it,
as far as its contacts and the scene allow.

The rules correct an object by closed-form steps, each right for the constraint it serves: a footprint step
inside the room, a snap to a wall, a push out of a neighbour, and every move of its parent carried along.
Together they can overshoot: a push of 4 cm per iteration ends a centimetre past the contact it sought, a
book stack follows its bookshelf's push although its own points did not move. An object's registered place
is evidence (it was registered on its own points); a correction beyond what its constraints need moves it
away from that evidence. So after depenetration, per generated object with points (parents before children,
``PASSES`` times), the horizontal step from its bounding-box centre to its registered one (for a mesh
resting on the floor or an object and levelled by more than ``evidence.LEVEL_REFIT_MIN_TILT_DEG``, the step fitting its levelled surface to its
points, ``evidence.refit_horizontal``: the registered box is the tilted mesh's) is tried whole and, for an object in contact with a wall, along that wall only: in each direction the whole step
when it keeps every constraint, else the longest fraction that does (bisection, ``SEARCH_STEPS``); of
those, the one ending nearest the registered centre is taken. The constraints:

* no colliding pair with a non-related object that it (or what it carries) did not have already;
* its footprint and those of what it carries stay inside the room (``refine.is_outside``), or, when one
  is not, it reaches no farther out;
* every wall contact stays one: no gap to a wall it touches grows (beyond ``wall_contact_gap``);
* a child resting on an object keeps its footprint centre over a support level of its parent at its
  bottom's height (``SUPPORT_HEIGHT_TOLERANCE``), the parent's mesh faces and its support planes.

Heights and orientations stay as the rules made them, so floor and support contacts hold. Exact shapes (the
ground-truth meshes of the benchmark's perturbed start) are not moved: their registered pose is the
perturbation, not evidence.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Point

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.compile_support import MIN_FACE_SHARE, support_levels
from rescene_core.assembly.evidence import (
    LEVEL_REFIT_MIN_TILT_DEG,
    containment_footprint,
    polygon_excursion,
    refit_horizontal,
    registered_tilt_deg,
)
from rescene_core.assembly.refine import is_outside
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.records import InstanceId, Relation

SEARCH_STEPS = 6
"""Bisection steps for the longest fraction of a step back that keeps every constraint (1/64 of the step),
when the whole step does not."""
PASSES = 2
"""Passes over the objects (a step taken frees space another object's step needs)."""
MIN_STEP = 0.002
"""Shortest step (m) worth taking."""
SUPPORT_HEIGHT_TOLERANCE = 0.02
"""A support level carries a child when it lies within this distance (m) of the child's bottom."""


def _wall_contacts(state: LayoutState, i: InstanceId) -> list:
    """Walls object i is in contact with: its gap to them within [0, ``wall_collision_margin``] (a gap may be
    slightly negative, the mesh touching the wall's plane), facing its segment."""
    verts = state.vertices(i)
    out = []
    for wall in state.room.walls:
        along = wall.along(verts)
        if along.max() <= 0.0 or along.min() >= wall.length:
            continue
        if float(wall.distance(verts).min()) <= state.config.wall_collision_margin:
            out.append(wall)
    return out


def _excursion(state: LayoutState, i: InstanceId) -> float:
    """How far (m) object i's containment footprint reaches beyond the floor polygon."""
    return polygon_excursion(state.room.polygon, containment_footprint(state, i))


def _wall_gaps(state: LayoutState, i: InstanceId, walls: list) -> list[float]:
    verts = state.vertices(i)
    return [float(wall.distance(verts).min()) for wall in walls]


def _keeps_walls(state: LayoutState, i: InstanceId, walls: list, gaps: list[float]) -> bool:
    """Whether object i keeps touching ``walls``: no gap grows beyond the larger of its ``gaps`` before the
    step and ``wall_contact_gap`` (a step back off a wall would open a gap up to the contact margin)."""
    limit = state.config.wall_contact_gap
    return all(now <= max(was, limit) + 1e-9 for now, was in zip(_wall_gaps(state, i, walls), gaps, strict=True))


def _supported(state: LayoutState, child: InstanceId) -> bool:
    """Whether ``child``'s footprint centre lies over a support level of its object parent at its bottom."""
    parent = state.forest.support_of(child)
    if parent is None:
        return True
    fp = state.footprint(child)
    bottom = float(state.room.floor_distance(state.vertices(child)).min())
    centre = fp.centroid
    smallest = MIN_FACE_SHARE * fp.area if not state.objects[parent].exact_shape else 0.0
    return any(
        abs(level.height - bottom) <= SUPPORT_HEIGHT_TOLERANCE
        and level.polygon.area >= smallest
        and level.polygon.contains(Point(centre.x, centre.y))
        for level in support_levels(state, parent)
    )


def _directions(state: LayoutState, i: InstanceId, walls: list) -> list[NDArray[np.float64]]:
    """Candidate horizontal world steps [3] back to the registered centre: the whole step, then its part
    along each wall object i is in contact with."""
    edge = state.forest.edges.get(i)
    rests = edge is not None and edge.relation is Relation.RESTS_ON
    if rests and registered_tilt_deg(state, i) > LEVEL_REFIT_MIN_TILT_DEG:
        # levelled by a large tilt where it rests (the floor and support rules fit it to its points): the
        # registered box is the tilted mesh's, not evidence of where the levelled one stands; its surface
        # fitted to the points is (``evidence.refit_horizontal``)
        refit = refit_horizontal(state, i, state.pose(i))
        step = np.zeros(3) if refit is None else refit
    else:
        seen = state.objects[i].world_vertices()
        step = 0.5 * (seen.min(axis=0) + seen.max(axis=0)) - state.centre(i)
    up = state.room.up
    step = step - (step @ up) * up
    directions = [step]
    for wall in walls:  # along the wall only: the part of the step that keeps the contact
        along = (step @ wall.tangent) * wall.tangent
        directions.append(along)
    return [d for d in directions if float(np.linalg.norm(d)) >= MIN_STEP]


def restore_toward_evidence(state: LayoutState, world: CollisionWorld, stage: str = "back toward evidence") -> int:
    """Run the stage (module docstring) in place; returns the number of steps taken."""
    order = list(state.forest.edges) + [i for i in state.objects if i not in state.forest.edges]
    taken = 0
    for _ in range(PASSES):
        for i in order:
            obj = state.objects[i]
            if i in state.unfit or obj.exact_shape or obj.points is None or len(obj.points) == 0:
                continue
            walls = _wall_contacts(state, i)
            directions = _directions(state, i, walls)
            if not directions:
                continue
            keeps = _checker(state, world, i, walls)
            steps = [(1.0 if keeps(d) else _longest(keeps, d)) * d for d in directions]
            # the step ending nearest the registered centre (directions[0] is the whole way there)
            step = min(steps, key=lambda st: float(np.linalg.norm(directions[0] - st)))
            if float(np.linalg.norm(step)) >= MIN_STEP:
                state.move(i, translation(step), stage, "back toward registered place", step_m=step)
                taken += 1
    return taken


def _checker(state: LayoutState, world: CollisionWorld, i: InstanceId, walls: list):
    """A test of a horizontal world step [3] of object i against the constraints (module docstring)."""
    carried = state.forest.subtree(i)
    poses = {j: state.pose(j) for j in state.objects}
    before = set(world.colliding_pairs(poses, skip=state.forest.related, only=carried))
    # what it carries goes along: none may leave the room, or reach farther out of it
    excursion = {j: (_excursion(state, j) if is_outside(state, j) else None) for j in carried}
    gaps = _wall_gaps(state, i, walls)

    def keeps(step: NDArray[np.float64]) -> bool:
        with state.trial(i, translation(step)) as moved:
            poses.update({j: state.pose(j) for j in moved})
            ok = (
                all(
                    not is_outside(state, j) or (was is not None and _excursion(state, j) <= was)
                    for j, was in excursion.items()
                )
                and _keeps_walls(state, i, walls, gaps)
                and _supported(state, i)
                and set(world.colliding_pairs(poses, skip=state.forest.related, only=carried)) <= before
            )
        poses.update({j: state.pose(j) for j in carried})
        return ok

    return keeps


def _longest(keeps, step: NDArray[np.float64]) -> float:
    """Longest fraction of ``step`` that ``keeps`` accepts, by bisection (SEARCH_STEPS; 0 when none): the
    constraints end where a neighbour, a wall or the edge of a support begins along the way."""
    lo, hi = 0.0, 1.0
    for _ in range(SEARCH_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if keeps(mid * step) else (lo, mid)
    return lo
