"""Propagation along the scene graph (paper Eq. 5), roots to leaves in topological order.

For each edge k = (c, r, p, omega): the child first inherits the parent's accumulated adjustment
Delta T_p (identity for a structural root), the relation is compiled against the parent's updated pose,
giving a world-frame correction C, and

    U_k = Delta T_p^-1 exp(omega log C) Delta T_p = exp(omega log(Delta T_p^-1 C Delta T_p)),
    Delta T_c = Delta T_p U_k = exp(omega log C) Delta T_p,

so omega = 0 leaves the child where its parent took it and omega = 1 satisfies the relation fully.
"""

from __future__ import annotations

import numpy as np

from rescene_core.assembly.compile_wall import resolve_walls
from rescene_core.assembly.dispatch import compile_edge
from rescene_core.assembly.state import LayoutState
from rescene_core.geometry.sim3 import inverse, scale_by_confidence
from rescene_core.records import Relation, Root


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
            state.skip(child, stage, info.get("reason", "rule did not apply"))
            continue
        weighted = scale_by_confidence(correction, edge.confidence)
        update = inverse(parent_delta) @ weighted @ parent_delta
        state.set_delta(
            child,
            parent_delta @ update,
            stage,
            f"{edge.relation.value} -> {edge.parent.value if isinstance(edge.parent, Root) else 'object'}",
            omega=float(edge.confidence),
            compiled=correction,
            transform=update,
            **info,
        )
        if "wall_id" in info:
            state.wall_of[child] = int(info["wall_id"])
