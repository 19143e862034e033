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
snap above the floor. Tilt, yaw and lateral moves stay scaled by omega.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.compile_wall import resolve_walls
from rescene_core.assembly.dispatch import compile_edge
from rescene_core.assembly.evidence import evidence_refuses, wall_gap
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.geometry.sim3 import inverse, scale_by_confidence
from rescene_core.records import InstanceId, Relation, Root


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
        parent_delta = np.eye(4) if isinstance(edge.parent, Root) else state.delta[edge.parent].copy()
        state.delta[child] = parent_delta.copy()
        state._version[child] += 1
        stage, correction, info = compile_edge(state, child, edge, plans)
        if correction is None:
            keep_registered(state, child)
            state.skip(child, stage, info.get("reason", "rule did not apply"))
            continue
        weighted = scale_by_confidence(correction, edge.confidence)
        update = inverse(parent_delta) @ weighted @ parent_delta
        closed = 0.0
        if edge.confidence < 1.0 and edge.confidence >= state.config.contact_closure_min_confidence:
            state.delta[child] = parent_delta @ update
            state._version[child] += 1
            closure, closed = contact_closure(state, child, info)
            update = inverse(parent_delta) @ closure @ weighted @ parent_delta
        refused = evidence_refuses(state, child, parent_delta @ update @ state.objects[child].world_from_asset)
        if refused is not None:
            keep_registered(state, child)
            state.skip(child, stage, refused)
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
