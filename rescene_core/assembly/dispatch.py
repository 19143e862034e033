"""The dispatch table: (relation, parent kind) -> the closed-form minimiser of that relation's energy.

A rule takes (state, child, edge, context) and returns (world-frame Sim(3) correction [4, 4] or None when
it cannot apply, and a dict saying what it did). Supporting a new relation type is one row here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.compile_floor import compile_floor
from rescene_core.assembly.compile_support import compile_support
from rescene_core.assembly.compile_wall import WallChoice, compile_wall
from rescene_core.assembly.state import LayoutState
from rescene_core.records import Edge, InstanceId, Relation, Root

Rule = Callable[[LayoutState, InstanceId, Edge, dict[InstanceId, WallChoice]], tuple[NDArray | None, dict[str, Any]]]


def parent_kind(edge: Edge) -> str:
    """'floor', 'wall' or 'object'."""
    return edge.parent.value if isinstance(edge.parent, Root) else "object"


DISPATCH: dict[tuple[Relation, str], tuple[str, Rule]] = {
    (Relation.RESTS_ON, "floor"): ("floor snap", lambda s, c, e, plans: compile_floor(s, c, e)),
    (Relation.MOUNTS_ON, "wall"): ("wall attachment", lambda s, c, e, plans: compile_wall(s, c, e, plans.get(c))),
    (Relation.RESTS_ON, "object"): ("object support", lambda s, c, e, plans: compile_support(s, c, e)),
}
"""(relation, parent kind) -> (stage name, rule)."""


def compile_edge(
    state: LayoutState, child: InstanceId, edge: Edge, plans: dict[InstanceId, WallChoice]
) -> tuple[str, NDArray[np.float64] | None, dict[str, Any]]:
    """Compile(r_k)(c_k, p_k) at the child's current pose: (stage, correction or None, info)."""
    row = DISPATCH.get((edge.relation, parent_kind(edge)))
    if row is None:
        return "relation", None, {"reason": f"no rule for {edge.relation.value} -> {parent_kind(edge)}"}
    stage, rule = row
    correction, info = rule(state, child, edge, plans)
    return stage, correction, info
