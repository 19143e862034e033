"""Relation-aware assembly: compile scene-graph edges into Sim(3) corrections, propagate them along the
graph, repair the layout against the room, and depenetrate (paper Sec. 3.4).

Public: ``attach(objects, graph, shell, config) -> Layout``, ``AssemblyObject``, and ``Operation`` (the typed
record of each solver step; ``operations_of`` reads ``Layout.operations`` back as records).
"""

from rescene_core.assembly.objects import AssemblyError, AssemblyObject, check_object
from rescene_core.assembly.operations import Operation, operations_of
from rescene_core.assembly.solver import attach

__all__ = ["AssemblyError", "AssemblyObject", "Operation", "attach", "check_object", "operations_of"]
