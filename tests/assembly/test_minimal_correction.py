"""The smallest correction: generated objects step back toward where they were registered as far as their
contacts allow, a parent's top grows under a child seen off it, and a parent taller than what stands on it
is cut where its children stand."""

from dataclasses import replace

import numpy as np
import pytest

from rescene_core.assembly import attach
from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.graph import build_forest
from rescene_core.assembly.refine import wall_snap
from rescene_core.assembly.restore import restore_toward_evidence
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.bench.assembly import metric_objects, visual_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import CompletionKind, Edge, InstanceId, Relation, Root, SceneGraph

A, B, T, L = InstanceId(1), InstanceId(2), InstanceId(3), InstanceId(4)


def _seen(obj, rng, n=400):
    """``obj`` with points sampled in its registered mesh box (generated, so the points are its evidence)."""
    v = obj.world_vertices()
    return replace(obj, points=rng.uniform(v.min(axis=0), v.max(axis=0), (n, 3)), exact_shape=False)


def _state(objects, edges=()):
    graph = SceneGraph(tuple(edges))
    room = room_from_shell(rect_room())
    return LayoutState(objects, build_forest(graph, set(objects)), room, AttachmentConfig()), CollisionWorld(objects)


def test_step_back_stops_where_a_neighbour_begins():
    rng = np.random.default_rng(0)
    a = _seen(box_object(1, "box", (0.4, 0.4, 0.4), placed(1.0, 2.0)), rng)
    b = box_object(2, "box", (0.4, 0.4, 0.4), placed(0.85, 2.0))  # overlaps a's registered place
    state, world = _state({A: a, B: b})
    state.move(A, translation([0.6, 0.0, 0.0]), "test", "pushed")
    restore_toward_evidence(state, world)
    # the step back ends where b begins (x 1.25), to within 1/64 of the step (0.6 m)
    assert 1.25 <= state.centre(A)[0] <= 1.25 + 0.6 / 64
    assert not world.colliding_pairs({i: state.pose(i) for i in state.objects})
    assert state.centre(B)[0] == pytest.approx(0.85)  # an exact shape's registered pose is not evidence


def test_step_back_keeps_a_wall_contact():
    rng = np.random.default_rng(1)
    a = _seen(box_object(1, "cabinet", (0.4, 0.4, 0.8), placed(3.5, 2.0)), rng)
    state, world = _state({A: a})
    state.move(A, translation([0.3 - 0.001, 0.3, 0.0]), "test", "snapped")  # back 1 mm from the x = 4 wall
    restore_toward_evidence(state, world)
    centre = state.centre(A)
    assert centre[1] == pytest.approx(2.0, abs=1e-6)  # along the wall: all the way back
    assert centre[0] == pytest.approx(3.799, abs=1e-6)  # across it: the contact stays


def _table_and_lamp(lamp_x: float, table_points_half_width: float):
    """A generated 0.6 m table (top at 0.7 m) whose points span +-``table_points_half_width`` m, and a
    generated lamp registered on the table's top at x = ``lamp_x``."""
    rng = np.random.default_rng(2)
    table = box_object(3, "table", (0.6, 0.6, 0.7), placed(2.0, 2.0), exact_shape=False)
    w = table_points_half_width
    top = np.c_[rng.uniform(2.0 - w, 2.0 + w, 800), rng.uniform(1.7, 2.3, 800), rng.uniform(0.69, 0.7, 800)]
    table = replace(table, points=top)
    lamp = _seen(box_object(4, "table lamp", (0.2, 0.2, 0.4), placed(lamp_x, 2.0, 0.7)), rng)
    graph = SceneGraph((Edge(T, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(L, Relation.RESTS_ON, T, 0.9)))
    return {T: table, L: lamp}, graph, rect_room()


def test_a_top_too_small_grows_under_a_child_seen_beyond_it():
    objects, graph, shell = _table_and_lamp(lamp_x=2.36, table_points_half_width=0.45)
    layout = attach(objects, graph, shell, AttachmentConfig())
    lamp = objects[L].world_vertices(layout.world_from_asset[L])
    assert 0.5 * (lamp[:, 0].min() + lamp[:, 0].max()) == pytest.approx(2.36, abs=1e-3)  # where it was seen
    assert lamp[:, 2].min() == pytest.approx(0.7, abs=0.005)
    grown = [c for c in layout.completions()[int(T)] if c.kind is CompletionKind.SUPPORT_PLANE]
    assert len(grown) == 1 and "grown under child 4" in grown[0].source
    m = structural_metrics(metric_objects(objects, layout), layout.world_from_asset, graph, shell)
    assert m["support_contact_pass"] == 1.0


def test_without_the_parent_seen_under_it_the_child_goes_onto_the_face():
    objects, graph, shell = _table_and_lamp(lamp_x=2.36, table_points_half_width=0.3)
    layout = attach(objects, graph, shell, AttachmentConfig())
    lamp = objects[L].world_vertices(layout.world_from_asset[L])
    assert 0.5 * (lamp[:, 0].min() + lamp[:, 0].max()) == pytest.approx(2.3, abs=1e-3)  # the face's edge
    assert int(T) not in layout.completions()


def _nightstand_and_lamp(points_top: float):
    """A generated nightstand mesh 0.75 m tall whose points (a dense top included) end at ``points_top``, and
    a generated lamp registered standing at 0.6 m."""
    rng = np.random.default_rng(3)
    stand = box_object(3, "nightstand", (0.5, 0.4, 0.75), placed(2.0, 2.0), exact_shape=False)
    sides = np.c_[rng.uniform(1.75, 2.25, 600), np.full(600, 1.8), rng.uniform(0.0, points_top, 600)]
    top = np.c_[
        rng.uniform(1.75, 2.25, 400), rng.uniform(1.8, 2.2, 400), rng.uniform(points_top - 0.01, points_top, 400)
    ]
    stand = replace(stand, points=np.vstack([sides, top]))
    lamp = _seen(box_object(4, "table lamp", (0.2, 0.2, 0.4), placed(2.0, 2.0, 0.6)), rng)
    graph = SceneGraph((Edge(T, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(L, Relation.RESTS_ON, T, 0.9)))
    return {T: stand, L: lamp}, graph, rect_room()


def test_a_parent_taller_than_what_stands_on_it_is_cut_there():
    objects, graph, shell = _nightstand_and_lamp(points_top=0.6)
    layout = attach(objects, graph, shell, AttachmentConfig())
    cuts = [c for c in layout.completions()[int(T)] if c.kind is CompletionKind.CUT]
    assert len(cuts) == 1
    stand = visual_objects(objects, layout)[T].world_vertices(layout.world_from_asset[T])
    assert stand[:, 2].max() == pytest.approx(0.6, abs=0.005)
    lamp = objects[L].world_vertices(layout.world_from_asset[L])
    assert lamp[:, 2].min() == pytest.approx(0.6, abs=0.005)  # not lifted 15 cm onto the invented top
    m = structural_metrics(metric_objects(objects, layout), layout.world_from_asset, graph, shell)
    assert m["support_contact_pass"] == 1.0


def test_a_parent_seen_up_to_its_top_is_not_cut():
    objects, graph, shell = _nightstand_and_lamp(points_top=0.75)
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert not [c for c in layout.completions().get(int(T), []) if c.kind is CompletionKind.CUT]
    lamp = objects[L].world_vertices(layout.world_from_asset[L])
    assert lamp[:, 2].min() == pytest.approx(0.75, abs=0.005)


def test_a_top_too_low_gives_way_to_the_surface_its_points_show():
    # the generated nightstand is 0.65 m tall; its points show its top at 0.70 m, where the lamp stands
    rng = np.random.default_rng(4)
    stand = box_object(3, "nightstand", (0.5, 0.4, 0.65), placed(2.0, 2.0), exact_shape=False)
    sides = np.c_[rng.uniform(1.75, 2.25, 600), np.full(600, 1.8), rng.uniform(0.0, 0.70, 600)]
    top = np.c_[rng.uniform(1.75, 2.25, 400), rng.uniform(1.8, 2.2, 400), rng.uniform(0.69, 0.70, 400)]
    stand = replace(stand, points=np.vstack([sides, top]))
    lamp = _seen(box_object(4, "table lamp", (0.2, 0.2, 0.4), placed(2.0, 2.0, 0.70)), rng)
    graph = SceneGraph((Edge(T, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(L, Relation.RESTS_ON, T, 0.9)))
    layout = attach({T: stand, L: lamp}, graph, rect_room(), AttachmentConfig())
    bottom = lamp.world_vertices(layout.world_from_asset[L])[:, 2].min()
    assert bottom == pytest.approx(0.70, abs=0.01)  # not dropped 5 cm onto the generated top
    planes = [c for c in layout.completions()[int(T)] if c.kind is CompletionKind.SUPPORT_PLANE]
    assert len(planes) == 1


@pytest.mark.parametrize(("depth", "snapped"), [(0.07, False), (0.4, True)])
def test_a_wall_snap_keeps_the_points_its_mesh_held(depth, snapped):
    """A bookshelf generated as a 7 cm slab of its seen front, registered 13 cm off the wall: pushing the
    slab to the wall leaves its points in front of it, so it keeps its place; a box as deep as its points
    is snapped."""
    rng = np.random.default_rng(3)
    y = 0.13 + depth / 2  # back 13 cm off the y = 0 wall
    shelf = _seen(box_object(1, "bookshelf", (0.7, depth, 1.7), placed(2.0, y)), rng)
    state, _ = _state({A: shelf})
    moved = wall_snap(state, A, max_gap=0.3, max_rot=np.radians(10.0), max_move=0.3, stage="test")
    assert moved is snapped
    back = state.vertices(A)[:, 1].min()
    if snapped:
        assert back == pytest.approx(state.config.wall_contact_gap, abs=1e-6)
    else:
        assert back == pytest.approx(0.13, abs=1e-9)
        assert any(op.rule == "skip" and "thinner than the object" in op.details["reason"] for op in state.operations)


def test_a_child_kept_at_its_registered_pose_stands_on_a_shelf_there():
    """Two book stacks seen on two shelves 9 cm apart inside a bookshelf generated without boards: the upper
    one's nearest face is the lower one's shelf, which would leave its points above it, so it keeps its
    registered pose and stands on a support plane at its registered bottom."""
    rng = np.random.default_rng(4)
    shelf = _seen(box_object(1, "bookshelf", (0.8, 0.35, 1.7), placed(2.0, 0.3)), rng)
    low = _seen(box_object(2, "book stack", (0.2, 0.25, 0.08), placed(1.75, 0.3, 1.2)), rng)
    high = _seen(box_object(3, "book stack", (0.2, 0.25, 0.08), placed(2.2, 0.3, 1.29)), rng)
    objects = {A: shelf, B: low, T: high}
    graph = SceneGraph(
        (
            Edge(A, Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(B, Relation.RESTS_ON, A, 0.9),
            Edge(T, Relation.RESTS_ON, A, 0.9),
        )
    )
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    np.testing.assert_allclose(layout.world_from_asset[T], high.world_from_asset, atol=1e-9)
    planes = [c for c in layout.completions()[A] if c.kind is CompletionKind.SUPPORT_PLANE]
    heights = sorted(
        float(np.mean((layout.world_from_asset[A] @ np.c_[c.points_asset, np.ones(len(c.points_asset))].T)[2]))
        for c in planes
    )
    assert any(h == pytest.approx(1.29, abs=1e-6) for h in heights)
    metrics = structural_metrics(metric_objects(objects, layout), layout.world_from_asset, graph, rect_room())
    assert int(T) not in metrics["contact_failures"]["support"]


def test_a_child_beyond_a_slab_parent_stands_where_the_parent_top_was_seen():
    """A cabinet generated as a 5 cm slab of its seen front (top at 0.75 m) whose points show its real top at
    0.78 m reaching 0.45 m back, and a lamp registered on that top 0.175 m beyond the slab: the lamp stays
    where it was seen, on a support plane at the seen top, not on the slab's edge."""
    rng = np.random.default_rng(5)
    cabinet = box_object(1, "cabinet", (0.8, 0.05, 0.75), placed(2.0, 0.3), exact_shape=False)
    top = np.c_[rng.uniform(1.6, 2.4, 2000), rng.uniform(0.275, 0.75, 2000), np.full(2000, 0.78)]
    cabinet = replace(cabinet, points=top)
    lamp = _seen(box_object(2, "table lamp", (0.2, 0.2, 0.4), placed(2.0, 0.5, 0.78)), rng)
    graph = SceneGraph((Edge(A, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(B, Relation.RESTS_ON, A, 0.9)))
    layout = attach({A: cabinet, B: lamp}, graph, rect_room(), AttachmentConfig())
    v = lamp.world_vertices(layout.world_from_asset[B])
    assert 0.5 * (v[:, 1].min() + v[:, 1].max()) == pytest.approx(0.5, abs=1e-3)
    assert v[:, 2].min() == pytest.approx(0.78, abs=0.005)
    planes = [c for c in layout.completions()[A] if c.kind is CompletionKind.SUPPORT_PLANE]
    assert planes
    metrics = structural_metrics(
        metric_objects({A: cabinet, B: lamp}, layout), layout.world_from_asset, graph, rect_room()
    )
    assert int(B) not in metrics["contact_failures"]["support"]


def test_books_registered_under_a_bookshelf_bottom_stand_on_its_bottom_board():
    """A bookshelf generated floating 6 cm above the floor (a base fills the gap) and books registered on its
    lowest shelf 2 cm below its mesh bottom: they stand on the parent's bottom board."""
    rng = np.random.default_rng(6)
    shelf = _seen(box_object(1, "bookshelf", (0.8, 0.35, 1.5), placed(2.0, 0.3, 0.06)), rng)
    books = _seen(box_object(2, "book stack", (0.3, 0.25, 0.15), placed(2.0, 0.3, 0.04)), rng)
    graph = SceneGraph((Edge(A, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(B, Relation.RESTS_ON, A, 0.9)))
    layout = attach({A: shelf, B: books}, graph, rect_room(), AttachmentConfig())
    metrics = structural_metrics(
        metric_objects({A: shelf, B: books}, layout), layout.world_from_asset, graph, rect_room()
    )
    assert int(B) not in metrics["contact_failures"]["support"]
    bottom = books.world_vertices(layout.world_from_asset[B])[:, 2].min()
    shelf_bottom = shelf.world_vertices(layout.world_from_asset[A])[:, 2].min()
    assert bottom == pytest.approx(shelf_bottom, abs=0.005)


def test_a_step_back_never_carries_a_child_out_of_the_room():
    """A table pushed 0.3 m off a wall carries a lamp that its re-seat left at the wall: the table's step
    back would take the lamp 0.2 m through the wall, so it stops where the lamp still fits."""
    rng = np.random.default_rng(8)
    table = _seen(box_object(1, "table", (1.0, 1.0, 0.75), placed(2.0, 0.6)), rng)
    lamp = _seen(box_object(2, "table lamp", (0.2, 0.2, 0.4), placed(2.0, 0.3, 0.75)), rng)
    state, world = _state(
        {A: table, B: lamp},
        (Edge(A, Relation.RESTS_ON, Root.FLOOR, 1.0), Edge(B, Relation.RESTS_ON, A, 0.9)),
    )
    state.move(A, translation([0.0, 0.3, 0.0]), "test", "pushed")  # the lamp goes along, to y 0.6
    state.move(B, translation([0.0, -0.5, 0.0]), "test", "re-seated")  # against the y = 0 wall
    restore_toward_evidence(state, world)
    for i in (A, B):
        assert state.vertices(i)[:, 1].min() >= -state.config.containment_tolerance - 1e-9
    assert state.centre(A)[1] < 0.9  # it still stepped back as far as the lamp allows


def test_a_support_plane_reaching_out_of_the_room_is_clipped_to_it():
    # a desk against the wall y = 0 carrying a plane grown under a child registered 0.3 m through that wall:
    # the part beyond the floor polygon goes, the part in the room stays at its height; a plane wholly
    # outside goes
    from rescene_core.assembly.completions import planes_within_room
    from rescene_core.geometry.sim3 import apply
    from rescene_core.records import Completion

    desk = box_object(1, "desk", (1.0, 0.6, 0.75), placed(2.0, 0.3))
    state, _ = _state({A: desk})
    pose = state.pose(A)
    grown = np.array([[1.5, -0.3, 0.75], [2.5, -0.3, 0.75], [2.5, 0.6, 0.75], [1.5, 0.6, 0.75]])
    outside = np.array([[1.5, -0.5, 0.75], [2.5, -0.5, 0.75], [2.5, -0.2, 0.75], [1.5, -0.2, 0.75]])
    for ring in (grown, outside):
        inverse_pose = np.linalg.inv(pose)
        state.add_completion(Completion(A, CompletionKind.SUPPORT_PLANE, apply(inverse_pose, ring), "test"))
    planes_within_room(state)
    (kept,) = state.completions[A]
    world = apply(pose, kept.points_asset)
    assert world[:, 1].min() == pytest.approx(0.0, abs=1e-9) and world[:, 1].max() == pytest.approx(0.6)
    assert world[:, 2] == pytest.approx(0.75)
    rules = [op.rule for op in state.operations]
    assert rules == ["support plane clipped to the room", "support plane outside the room"]
