"""Containment in a room larger than what was seen, and the correction bound: a shell whose seen floor is a
2 x 2 m patch with walls on two sides (the other two open), a kitchen island and its cup standing beyond the
patch on floor never in view."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point

from rescene_core.assembly import attach
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.config import AttachmentConfig
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

PATCH = ((0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0))
ISLAND, CUP = InstanceId(10), InstanceId(11)


def _patch_shell(open_sides: bool = True) -> RoomShell:
    """The seen patch; walls on y = 0 (id 0, edge 0) and x = 0 (id 1, edge 3); edges 1 and 2 open (with
    ``open_sides``; otherwise a version-1 shell, every edge taken as walled)."""
    walls = (
        WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (2.0, 0.0))),
        WallPlane(1, Plane((1.0, 0.0, 0.0), 0.0), ((0.0, 2.0), (0.0, 0.0))),
    )
    edge_walls = (0, None, None, 1) if open_sides else None
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), walls, PATCH, 2.5, edge_walls, PATCH if open_sides else None)


def _island_scene():
    island = box_object(ISLAND, "kitchen island", (1.2, 0.8, 0.9), placed(3.4, 1.0))
    cup = box_object(CUP, "cup", (0.08, 0.08, 0.1), placed(3.2, 1.1, 0.9))
    graph = SceneGraph((Edge(ISLAND, Relation.RESTS_ON, Root.FLOOR), Edge(CUP, Relation.RESTS_ON, ISLAND)))
    return {ISLAND: island, CUP: cup}, graph


def _centre_move(obj, pose) -> np.ndarray:
    before, after = obj.world_vertices(), obj.world_vertices(pose)
    return 0.5 * (after.min(0) + after.max(0)) - 0.5 * (before.min(0) + before.max(0))


def test_open_sides_reach_beyond_the_patch_but_not_behind_a_wall():
    room = room_from_shell(_patch_shell())
    assert room.floor_extent is not None and room.floor_extent.area == pytest.approx(4.0)
    assert room.polygon is not None and room.polygon.contains(room.floor_extent)
    for x, y in [(3.4, 1.0), (1.0, 5.0), (6.0, 6.0)]:  # across the open edges and their corner
        assert room.polygon.contains(Point(x, y))
    for x, y in [(1.0, -0.5), (-0.5, 1.0)]:  # behind the observed walls
        assert not room.polygon.contains(Point(x, y))
    assert any("no observed wall" in note for note in room.notes)


def test_island_beyond_an_open_side_is_not_moved():
    objects, graph = _island_scene()
    layout = attach(objects, graph, _patch_shell(), AttachmentConfig())
    for i, obj in objects.items():
        np.testing.assert_allclose(layout.world_from_asset[i], obj.world_from_asset, atol=1e-9)
    assert not [op for op in layout.operations if op["stage"] in ("outside repair", "final containment")]


def test_bound_clips_a_large_correction_and_says_so():
    # read as a version-1 shell every edge is walled: the island is 0.8-2 m outside, and without the bound
    # the containment repairs carry it (and its cup) more than 1.5 m into the patch
    objects, graph = _island_scene()
    free = attach(objects, graph, _patch_shell(open_sides=False), AttachmentConfig(max_correction_m=None))
    assert np.linalg.norm(_centre_move(objects[ISLAND], free.world_from_asset[ISLAND])[:2]) > 1.5
    cfg = AttachmentConfig()
    layout = attach(objects, graph, _patch_shell(open_sides=False), cfg)
    moved = np.linalg.norm(_centre_move(objects[ISLAND], layout.world_from_asset[ISLAND])[:2])
    assert moved == pytest.approx(cfg.max_correction_m, abs=1e-6)
    # the cup, still over the island's top, stays where it was seen; no containment repair of its own
    assert np.linalg.norm(_centre_move(objects[CUP], layout.world_from_asset[CUP])[:2]) < 1e-6
    skips = [op for op in layout.operations if op["instance"] == int(CUP) and op["rule"] == "skip"]
    assert skips and all("its parent 10 is outside" in op["reason"] for op in skips)
    clipped = [op for op in layout.operations if op["instance"] == int(ISLAND) and "bound_clipped" in op]
    assert clipped and all(op["bound_clipped"]["max_correction_m"] == cfg.max_correction_m for op in clipped)
    assert max(op["bound_clipped"]["wanted_m"] for op in clipped) > 1.0


def test_object_through_an_observed_wall_is_moved_out_past_the_bound():
    # a cabinet registered 0.7 m through the south wall is in collision with it: moved out in full
    shell = rect_room()
    cabinet = box_object(1, "cabinet", (0.8, 0.5, 1.0), placed(2.0, -0.45))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR),))
    layout = attach({cabinet.instance: cabinet}, graph, shell, AttachmentConfig())
    verts = cabinet.world_vertices(layout.world_from_asset[cabinet.instance])
    assert verts[:, 1].min() >= -0.01 and np.linalg.norm(_centre_move(cabinet, layout.world_from_asset[1])) > 0.6
    assert not [op for op in layout.operations if "bound_clipped" in op]


def test_objects_in_collision_are_separated_past_the_bound():
    # two boxes registered 6 cm into each other: depenetration separates them even with a 1 cm bound
    shell = rect_room()
    a = box_object(1, "box", (0.6, 0.6, 0.6), placed(1.5, 2.5))
    b = box_object(2, "box", (0.6, 0.6, 0.6), placed(2.04, 2.5))
    graph = SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR) for i in (1, 2)))
    objects = {a.instance: a, b.instance: b}
    layout = attach(objects, graph, shell, AttachmentConfig(max_correction_m=0.01))
    gap = (
        a.world_vertices(layout.world_from_asset[1])[:, 0].max()
        - b.world_vertices(layout.world_from_asset[2])[:, 0].min()
    )
    assert gap <= 1e-6  # no longer overlapping
    pushed = [op for op in layout.operations if op["stage"].startswith("depenetration") and "moved" in op]
    assert pushed and not [op for op in pushed if "bound_clipped" in op]
    total = sum(np.linalg.norm(_centre_move(o, layout.world_from_asset[i])[:2]) for i, o in objects.items())
    assert total > 0.05


def test_bound_is_not_applied_when_unset():
    objects, graph = _island_scene()
    shell = _patch_shell(open_sides=False)
    layout = attach(objects, graph, shell, AttachmentConfig(max_correction_m=None))
    assert not [op for op in layout.operations if "bound_clipped" in op]
