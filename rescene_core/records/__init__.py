"""Typed records handed between the stages of the pipeline, one module per kind of record (``ids``,
``capture``, ``shell``, ``objects``, ``graph``, ``missing``, ``layout``, ``refs``); import them from here.

Every record is a frozen dataclass. Array fields say their dtype, shape, units and frame in the
docstring; conventions follow DESIGN.md: metres, world z up, OpenCV cameras (x right, y down,
z forward), and ``a_from_b`` transforms that map frame-b points into frame a.

Records that go to disk have ``to_json`` / ``from_json`` with plain JSON types only (no pickles).
"""

from rescene_core.records.capture import Camera, Instance, InstancePoints
from rescene_core.records.graph import Edge, SceneGraph
from rescene_core.records.ids import (
    STRUCTURAL_LABELS,
    InstanceId,
    Parent,
    Relation,
    Root,
    Stage,
    parent_from_json,
    parent_to_json,
)
from rescene_core.records.layout import Completion, CompletionKind, Layout, Operation, completion_of_operation
from rescene_core.records.missing import Missing
from rescene_core.records.objects import Asset, Pose, ViewChoice
from rescene_core.records.refs import Ref, RefStatus
from rescene_core.records.shell import SHELL_VERSION, Plane, RoomShell, WallPlane

__all__ = [
    "Asset",
    "Camera",
    "Completion",
    "CompletionKind",
    "Edge",
    "Instance",
    "InstanceId",
    "InstancePoints",
    "Layout",
    "Missing",
    "Operation",
    "Parent",
    "Plane",
    "Pose",
    "Ref",
    "RefStatus",
    "Relation",
    "RoomShell",
    "Root",
    "SHELL_VERSION",
    "STRUCTURAL_LABELS",
    "SceneGraph",
    "Stage",
    "ViewChoice",
    "WallPlane",
    "completion_of_operation",
    "parent_from_json",
    "parent_to_json",
]
