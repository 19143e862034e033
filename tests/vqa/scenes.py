"""A small hand-built bedroom with known geometry: room 5 m (x, west -> east) by 4 m (y, south -> north)."""

from __future__ import annotations

from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane
from rescene_core.vqa import VqaObject, VqaScene

BED, NIGHTSTAND, LAMP, PICTURE, CHAIR = 1, 2, 3, 4, 5
NORTH_WALL = 2


def room_shell() -> RoomShell:
    walls = (
        WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((5.0, 0.0), (0.0, 0.0))),  # south, y = 0
        WallPlane(1, Plane((-1.0, 0.0, 0.0), 5.0), ((5.0, 4.0), (5.0, 0.0))),  # east, x = 5
        WallPlane(NORTH_WALL, Plane((0.0, -1.0, 0.0), 4.0), ((0.0, 4.0), (5.0, 4.0))),  # north, y = 4
        WallPlane(3, Plane((1.0, 0.0, 0.0), 0.0), ((0.0, 0.0), (0.0, 4.0))),  # west, x = 0
    )
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), walls, ((0.0, 0.0), (5.0, 0.0), (5.0, 4.0), (0.0, 4.0)), 2.6)


def bedroom_objects() -> list[VqaObject]:
    return [
        VqaObject.box(BED, "bed", (2.5, 3.0, 0.25), (1.6, 2.0, 0.5)),
        VqaObject.box(NIGHTSTAND, "nightstand", (1.2, 3.6, 0.275), (0.5, 0.4, 0.55)),
        VqaObject.box(LAMP, "lamp", (1.2, 3.6, 0.75), (0.2, 0.2, 0.4)),
        VqaObject.box(PICTURE, "picture", (2.5, 3.98, 1.5), (0.8, 0.04, 0.6)),
        VqaObject.box(CHAIR, "chair", (4.0, 1.0, 0.45), (0.5, 0.5, 0.9)),
    ]


def bedroom_edges(lamp_confidence: float = 0.9) -> list[Edge]:
    return [
        Edge(InstanceId(BED), Relation.RESTS_ON, Root.FLOOR, 0.95),
        Edge(InstanceId(NIGHTSTAND), Relation.RESTS_ON, Root.FLOOR, 0.9),
        Edge(InstanceId(LAMP), Relation.RESTS_ON, InstanceId(NIGHTSTAND), lamp_confidence),
        Edge(InstanceId(PICTURE), Relation.MOUNTS_ON, Root.WALL, 0.9, wall_id=NORTH_WALL),
        Edge(InstanceId(CHAIR), Relation.RESTS_ON, Root.FLOOR, 0.9),
    ]


def make_bedroom(lamp_confidence: float = 0.9, extra: list[VqaObject] = (), extra_edges: list[Edge] = ()) -> VqaScene:
    return VqaScene(
        tuple(bedroom_objects()) + tuple(extra),
        SceneGraph(tuple(bedroom_edges(lamp_confidence)) + tuple(extra_edges)),
        room_shell(),
        scene_id="bedroom",
    )
