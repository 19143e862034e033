"""Propagation along the scene graph (paper Eq. 5), roots to leaves in topological order.

For each edge k = (c, r, p, omega): the child first inherits the parent's accumulated adjustment
Delta T_p (identity for a structural root), the relation is compiled against the parent's updated pose,
giving a world-frame correction C, and

    U_k = Delta T_p^-1 exp(omega log C) Delta T_p = exp(omega log(Delta T_p^-1 C Delta T_p)),
    Delta T_c = Delta T_p U_k = exp(omega log C) Delta T_p,

so omega = 0 leaves the child where its parent took it and omega = 1 satisfies the relation fully.

Contact closure: an edge at least ``contact_closure_min_confidence`` confident then gets the rest of its
contact along the contact normal (floor: the lowest point onto the floor; object support: the lowest point
onto the chosen support level; wall: the back surface onto the wall plane, read as in
``rescene_core.assembly.evidence.wall_gap``) as a pure translation, composed into the same update. A
confident relation is either a contact or not: omega < 1 alone would leave an object (1 - omega) of its
snap above the floor. For the same reason such a wall edge also takes its rotation onto the wall in full
(``turn_in_full``): a back left (1 - omega) of its yaw off the wall touches it along one edge only. Lateral
moves, and the tilt and yaw of floor and support edges, stay scaled by omega.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely
from numpy.typing import NDArray

from rescene_core.assembly.compile_wall import resolve_walls
from rescene_core.assembly.completions import BASE_MIN_GAP, BASE_MIN_POINTS, FIT_TIE, bounded_floor_snap
from rescene_core.assembly.dispatch import compile_edge
from rescene_core.assembly.evidence import evidence_refuses, points_fit, wall_gap
from rescene_core.assembly.objects import footprint
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.geometry.sim3 import apply, inverse, scale_by_confidence
from rescene_core.records import Edge, InstanceId, Relation, Root


def contact_closure(state: LayoutState, child: InstanceId, info: dict) -> tuple[NDArray[np.float64], float]:
    """Translation [4, 4] closing what is left of ``child``'s contact at its current pose, and its length
    (m, signed along the contact normal); identity when the rule named no contact."""
    cfg, room = state.config, state.room
    verts = state.vertices(child)
    if "level_height_m" in info:  # object support
        step = float(info["level_height_m"]) - float(room.floor_distance(verts).min())
        step = float(np.clip(step, -cfg.max_support_snap, cfg.max_support_snap))
        return translation(step * room.up), step
    if "wall_id" in info:  # wall attachment
        wall = room.wall(int(info["wall_id"]))
        if wall is None:
            return np.eye(4), 0.0
        step = -wall_gap(state, child, wall)
        return translation(step * wall.normal), step
    if "vertical_m" in info:  # floor snap
        step = -float(room.floor_distance(verts).min())
        step = float(np.clip(step, -cfg.max_floor_snap, cfg.max_floor_snap))
        return translation(step * room.up), step
    return np.eye(4), 0.0


def turn_in_full(correction: NDArray, weight: float, centre: NDArray) -> NDArray[np.float64]:
    """``correction`` [4, 4] (world frame) with its rotation taken in full about ``centre`` [3] (m) and the
    move of that centre scaled by ``weight``."""
    linear = np.asarray(correction, np.float64)[:3, :3]
    moved = linear @ centre + correction[:3, 3]
    out = np.eye(4)
    out[:3, :3] = linear
    out[:3, 3] = centre + weight * (moved - centre) - linear @ centre
    return out


def keep_registered(state: LayoutState, child: InstanceId) -> None:
    """A child whose relation cannot be satisfied stays where it was registered, not where its parent's
    correction carried it (a book stack on a desk the floor snap lowered by 0.19 m would otherwise sink
    0.19 m into it)."""
    state.delta[child] = np.eye(4)
    state._version[child] += 1


def propagate(state: LayoutState, use_walls: bool = True) -> None:
    """Apply every edge of the forest in topological order (in place). ``use_walls=False`` is the
    floor-only branch: ``mounts-on wall`` edges are skipped and their children keep their poses."""
    plans = resolve_walls(state) if use_walls else {}
    for child, edge in state.forest.edges.items():
        if not use_walls and edge.relation is Relation.MOUNTS_ON and edge.parent is Root.WALL:
            state.skip(child, "wall attachment", "floor-only branch leaves wall edges out")
            continue
        edge = trusted_floor_edge(state, child, edge)
        parent_delta = np.eye(4) if isinstance(edge.parent, Root) else state.delta[edge.parent].copy()
        if edge.relation is Relation.RESTS_ON and not isinstance(edge.parent, Root):
            parent_delta = support_step(state, child, parent_delta)
        state.delta[child] = parent_delta.copy()
        state._version[child] += 1
        stage, correction, info = compile_edge(state, child, edge, plans)
        if correction is None:
            keep_registered(state, child)
            state.skip(child, stage, info.get("reason", "rule did not apply"))
            continue
        closing = 1.0 > edge.confidence >= state.config.contact_closure_min_confidence
        if closing and "wall_id" in info:
            weighted = turn_in_full(correction, edge.confidence, state.centre(child))
        else:
            weighted = scale_by_confidence(correction, edge.confidence)
        update = inverse(parent_delta) @ weighted @ parent_delta
        closed = 0.0
        if closing:
            state.delta[child] = parent_delta @ update
            state._version[child] += 1
            closure, closed = contact_closure(state, child, info)
            update = inverse(parent_delta) @ closure @ weighted @ parent_delta
        target = parent_delta @ update @ state.objects[child].world_from_asset
        refused = evidence_refuses(state, child, target)
        if edge.parent is Root.FLOOR and edge.relation is Relation.RESTS_ON and has_evidence(state, child):
            pose, taken, why = bounded_floor_snap(state, child, target)
            if taken < 1.0:
                floor_with_base(state, child, edge, pose, taken, stage, why or refused, info)
                continue
        if refused is not None:
            keep_registered(state, child)
            state.skip(child, stage, refused)
            if "level_height_m" in info and not isinstance(edge.parent, Root):
                support_with_base(state, child, edge.parent, edge, float(info["level_height_m"]))
            if "wall_id" in info:
                state.wall_base_wanted[child] = (int(info["wall_id"]), refused)
            continue
        over = state.over_bound(child, parent_delta @ update) if "wall_id" in info else None
        if over is not None:
            # cut short, a wall contact is no contact: the object stays where it was seen
            keep_registered(state, child)
            state.log(
                child,
                stage,
                "skip",
                reason=f"the wall is {over['wanted_m']:.3f} m away, more than max_correction_m = "
                f"{over['max_correction_m']} m: the object keeps its registered pose",
                bound_clipped={**over, "taken_m": 0.0},
            )
            continue
        state.set_delta(
            child,
            parent_delta @ update,
            stage,
            f"{edge.relation.value} -> {edge.parent.value if isinstance(edge.parent, Root) else 'object'}",
            omega=float(edge.confidence),
            compiled=correction,
            transform=update,
            contact_closed_m=closed,
            **info,
        )
        if "wall_id" in info:
            state.wall_of[child] = int(info["wall_id"])


def support_step(state: LayoutState, child: InstanceId, parent_delta: NDArray) -> NDArray[np.float64]:
    """What a generated ``child`` with observed points inherits of its support's Delta T ``parent_delta``
    [4, 4] before its own rule runs: only the support's vertical step where the child stands (at its
    registered footprint centre and bottom), and only when the child's points agree with that step (its mesh
    box explains them within ``completions.FIT_TIE`` as well as at the registered pose); else nothing, the
    registered pose. An exact shape, or a child without points, inherits the whole of ``parent_delta``.

    A child was registered on its own points: its support's levelling, yaw or footprint step (a counter or a
    desk moved a few centimetres into the floor polygon) is not evidence of where the child stands. The
    child's rule then puts it on the face at its registered centre, but scaled by the edge's confidence
    (Eq. 5), so an edge at 0.87 kept 13 % of its support's horizontal step and of its turn."""
    obj = state.objects[child]
    if obj.exact_shape or obj.points is None or len(obj.points) == 0:
        return parent_delta
    room = state.room
    verts = obj.world_vertices()
    foot = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
    foot = foot - float(room.floor_distance(foot[None])[0] - room.floor_distance(verts).min()) * room.up
    step = float((apply(parent_delta, foot[None])[0] - foot) @ room.up)
    carried = translation(step * room.up)
    before = points_fit(obj, obj.world_from_asset)
    after = points_fit(obj, carried @ obj.world_from_asset)
    if before is None or after is None or after >= before - FIT_TIE:
        return carried
    return np.eye(4)


BENEATH_MIN_SHARE = 0.2
"""Another object whose footprint covers at least this share of an object's footprint, entirely below its
bottom, is something it may stand on."""
BENEATH_TOLERANCE = 0.05
"""... 'below' allowing this much (m) of registration overlap."""


def nothing_beneath(state: LayoutState, i: InstanceId) -> bool:
    """Whether no other object (outside i's subtree) lies under object i at the registered poses: then the
    floor is the only thing it can rest on."""
    room = state.room
    obj = state.objects[i]
    verts = obj.world_vertices()
    fp = footprint(verts)
    bottom = float(room.floor_distance(verts).min())
    own = set(state.forest.subtree(i))
    for j, other in state.objects.items():
        if j in own:
            continue
        ov = other.world_vertices()
        if float(room.floor_distance(ov).max()) > bottom + BENEATH_TOLERANCE:
            continue
        if fp.area > 0 and fp.intersection(footprint(ov)).area >= BENEATH_MIN_SHARE * fp.area:
            return False
    return True


def trusted_floor_edge(state: LayoutState, child: InstanceId, edge: Edge) -> Edge:
    """``edge``, or, for a ``rests-on floor`` edge below ``contact_closure_min_confidence`` (and at least
    ``floor_trust_min_confidence``) whose child has nothing beneath it, the same edge at confidence 1 (logged): an object rests on something, and the floor
    is all there is under it, so a snap part way would leave it floating (a nightstand seen only over a
    bed, fused at 0.4)."""
    if not (edge.parent is Root.FLOOR and edge.relation is Relation.RESTS_ON):
        return edge
    cfg = state.config
    if edge.confidence >= cfg.contact_closure_min_confidence or cfg.floor_trust_min_confidence is None:
        return edge
    if edge.confidence < cfg.floor_trust_min_confidence or not nothing_beneath(state, child):
        return edge
    state.log(
        child,
        "floor snap",
        "trust floor edge",
        confidence=float(edge.confidence),
        reason="nothing lies beneath the object: the floor is the only support it can have",
    )
    return replace(edge, confidence=1.0)


def has_evidence(state: LayoutState, i: InstanceId) -> bool:
    """Whether object i is a generated asset with observed points that bound its moves."""
    obj = state.objects[i]
    return not obj.exact_shape and obj.points is not None and len(obj.points) > 0


def floor_with_base(
    state: LayoutState,
    child: InstanceId,
    edge: Edge,
    pose: NDArray,
    taken: float,
    stage: str,
    refused: str | None,
    info: dict,
) -> None:
    """A floor snap the child's points would explain worse than a smaller one, or that would lower the top
    they show (its generated mesh lacks its lower part): ``pose``, the part of the snap the points allow
    (``completions.bounded_floor_snap``, ``taken`` of it; ``refused``: why not all of it), and a base under the mesh at the final pose when the edge is confident enough to close
    its contact (``contact_closure_min_confidence``)."""
    registered = state.objects[child].world_from_asset
    still = evidence_refuses(state, child, pose)
    reason = refused or "the full snap would explain fewer of the object's observed points"
    if still is None:
        state.set_delta(
            child,
            pose @ inverse(registered),
            stage,
            "rests-on -> floor, bounded by points",
            omega=float(edge.confidence),
            snap_taken=taken,
            reason=reason,
            **{k: v for k, v in info.items() if k != "vertical_m"},
        )
    else:
        keep_registered(state, child)
        state.skip(child, stage, still)
    if edge.confidence >= state.config.contact_closure_min_confidence:
        state.base_wanted[child] = (
            "the object's observed points keep its generated mesh above the floor it rests on "
            f"({taken:.0%} of the floor snap taken): a base fills the gap"
        )


SUPPORT_REACH = 0.03
"""An object kept above its support reaches it when at least BASE_MIN_POINTS of its observed points (within
this distance, m, of its mesh's footprint) lie within this distance of the support's level and as many
between there and its mesh's bottom (a stem seen whole, not a few points bled from the support)."""


def support_with_base(state: LayoutState, child: InstanceId, parent: InstanceId, edge: Edge, level: float) -> None:
    """``child`` keeps its registered pose above ``parent`` (``edge``'s; the support correction would leave its observed
    points outside its mesh); when its mesh hangs above the support ``level`` (m above the floor) and its
    observed points reach down to it, the generated mesh lacks its lower part (a lamp's stem): a base from
    the support up into the mesh is wanted (``completions.add_bases``), recorded against the parent's
    lowest point so it follows the parent's later moves."""
    if not has_evidence(state, child) or edge.confidence < state.config.contact_closure_min_confidence:
        return
    room, obj = state.room, state.objects[child]
    verts = state.vertices(child)
    bottom = float(room.floor_distance(verts).min())
    if bottom - level < BASE_MIN_GAP:
        return
    pts = apply(state.pose(child) @ inverse(obj.world_from_asset), np.asarray(obj.points, np.float64))
    fp = footprint(verts).buffer(SUPPORT_REACH)
    pts = pts[shapely.contains_xy(fp, pts[:, 0], pts[:, 1])]
    h = room.floor_distance(pts)
    at_support = int(np.count_nonzero(np.abs(h - level) <= SUPPORT_REACH))
    between = int(np.count_nonzero((h > level + SUPPORT_REACH) & (h < bottom)))
    if at_support < BASE_MIN_POINTS or between < BASE_MIN_POINTS:
        return  # the capture did not see the object reach down to its support: no base is evidence-derived
    seen_low = float(h[np.abs(h - level) <= SUPPORT_REACH].min())
    parent_bottom = float(room.floor_distance(state.vertices(parent)).min())
    state.support_base_wanted[child] = (
        parent,
        level - parent_bottom,
        f"the object's observed points reach down to its support ({seen_low:.3f} m, the support at {level:.3f} m) "
        f"but its generated mesh ends {bottom - level:.3f} m above it, and the support correction would leave "
        "its points outside its mesh: a base fills the gap",
    )
