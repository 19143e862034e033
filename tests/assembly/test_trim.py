"""Cuts of a generated completion that reaches through the floor or a wall beyond the object's points."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import trimesh

from rescene_core.assembly import attach
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.assembly.trim import room_cuts
from rescene_core.bench.assembly import metric_objects, visual_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import CompletionKind, Edge, InstanceId, Relation, Root, SceneGraph


def _desk(depth_m: float, points_back_y: float):
    """A desk 1.2 x depth x 0.75 against the y = 0 wall of ``rect_room`` with its front face at y = 0.6,
    seen from the room: points on its front and top down to ``points_back_y``."""
    rng = np.random.default_rng(0)
    front = np.c_[rng.uniform(1.4, 2.6, 800), np.full(800, 0.6), rng.uniform(0.0, 0.75, 800)]
    top = np.c_[rng.uniform(1.4, 2.6, 800), rng.uniform(points_back_y, 0.6, 800), np.full(800, 0.75)]
    desk = box_object(1, "desk", (1.2, depth_m, 0.75), placed(2.0, 0.6 - depth_m / 2), exact_shape=False)
    return replace(desk, points=np.vstack([front, top]))


def test_a_completion_through_the_wall_is_cut_there_and_the_desk_is_not_moved():
    desk = _desk(0.8, points_back_y=0.02)  # 0.2 m of completion behind the wall at y = 0
    room = room_from_shell(rect_room())
    (cut,) = room_cuts(desk, room)
    assert cut.kind is CompletionKind.CUT and "wall" in cut.source
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    cfg = AttachmentConfig(near_wall_snap=False)
    layout = attach({InstanceId(1): desk}, graph, rect_room(), cfg)
    # nothing moved it off its points: the crossing is gone with the cut
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(1)], desk.world_from_asset, atol=1e-9)
    shown = visual_objects({InstanceId(1): desk}, layout)[InstanceId(1)]
    world = shown.world_vertices(layout.world_from_asset[InstanceId(1)])
    assert abs(world[:, 1].min()) < 1e-6 and abs(world[:, 1].max() - 0.6) < 1e-6
    assert trimesh.Trimesh(shown.vertices, shown.faces).is_watertight
    m = structural_metrics(metric_objects({InstanceId(1): desk}, layout), layout, graph, rect_room())
    assert m["oob_rate"] == 0.0 and m["floor_contact_pass"] == 1.0
    # without trimming the rules move the whole desk 0.2 m off its front
    moved = attach({InstanceId(1): desk}, graph, rect_room(), cfg.model_copy(update={"trim_completions": False}))
    assert moved.world_from_asset[InstanceId(1)][1, 3] - desk.world_from_asset[1, 3] > 0.19


def test_a_sunk_completion_is_cut_at_the_floor_where_its_points_end():
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(1.0, 2.8, 900), np.full(900, 2.0), rng.uniform(0.0, 0.85, 900)]
    sofa = replace(box_object(1, "sofa", (1.8, 0.9, 0.95), placed(1.9, 2.45, -0.07), exact_shape=False), points=pts)
    (cut,) = room_cuts(sofa, room_from_shell(rect_room()))
    assert "floor" in cut.source
    origin, tip = cut.points_asset
    np.testing.assert_allclose(origin[2] + sofa.world_from_asset[2, 3], 0.0, atol=1e-9)
    np.testing.assert_allclose(tip - origin, [0, 0, 1], atol=1e-9)
    # points reaching 3 cm below the floor (a floor plane estimated 3 cm high): the cut follows them
    low = replace(sofa, points=pts - [0.0, 0.0, 0.03])
    (cut,) = room_cuts(low, room_from_shell(rect_room()))
    reach = np.percentile(low.points[:, 2], 1.0)  # the points' reach: their 1st percentile, about -0.02 m
    assert -0.03 < reach < 0.0
    np.testing.assert_allclose(cut.points_asset[0][2] + sofa.world_from_asset[2, 3], reach, atol=1e-9)


def test_no_cut_for_exact_shapes_small_crossings_or_a_pose_mostly_beyond_the_wall():
    room = room_from_shell(rect_room())
    desk = _desk(0.8, points_back_y=0.02)
    assert room_cuts(replace(desk, exact_shape=True), room) == []
    assert room_cuts(_desk(0.605, points_back_y=0.02), room) == []  # 5 mm through: within the margin
    # registered with most of the mesh behind the wall: the pose is wrong, the rules repair it
    far = replace(desk, world_from_asset=placed(2.0, -0.2))
    assert room_cuts(far, room) == []


def _front_and_side_points(rng, x0, x1, side_x, height):
    """Points on a wardrobe's front (y = 1.7, x0..x1) and on its outer side (x = side_x)."""
    front = np.c_[rng.uniform(x0, x1, 600), np.full(600, 1.7), rng.uniform(0.0, height, 600)]
    side = np.c_[np.full(300, side_x), rng.uniform(1.7, 2.3, 300), rng.uniform(0.0, height, 300)]
    return np.vstack([front, side])


def test_two_completions_filling_the_same_space_are_cut_where_one_was_not_seen():
    # two wardrobes side by side, 0.9 m wide, seen from the front and their outer sides; the left one's
    # completion is 0.1 m too wide and fills the right one's space
    rng = np.random.default_rng(5)
    left = box_object(1, "wardrobe", (1.0, 0.6, 2.0), placed(1.5, 2.0), exact_shape=False)
    right = box_object(2, "wardrobe", (0.9, 0.6, 2.0), placed(2.35, 2.0), exact_shape=False)
    left = replace(left, points=_front_and_side_points(rng, 1.0, 1.9, 1.0, 2.0))
    right = replace(right, points=_front_and_side_points(rng, 1.9, 2.8, 2.8, 2.0))
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 1.0),
        )
    )
    objects = {InstanceId(1): left, InstanceId(2): right}
    cfg = AttachmentConfig(near_wall_snap=False, depenetration_max_fit_drop=0.0)  # both held where seen
    layout = attach(objects, graph, rect_room(), cfg)
    cuts = [op for op in layout.operations if op["rule"] == "cut overlap"]
    assert [op["instance"] for op in cuts] == [1]  # the one not seen in the overlap
    scene = metric_objects(objects, layout)
    assert structural_metrics(scene, layout, graph, rect_room())["collision_pairs"] == 0
    # neither was moved off its points (pushes stay within the 3 cm surface margin of evidence.surface_fit)
    for i in objects:
        shift = layout.world_from_asset[i][:3, 3] - objects[i].world_from_asset[:3, 3]
        assert np.linalg.norm(shift) <= 0.031
    # without cuts the overlap stays
    plain = attach(objects, graph, rect_room(), cfg.model_copy(update={"trim_completions": False}))
    assert structural_metrics(metric_objects(objects, plain), plain, graph, rect_room())["collision_pairs"] == 1


def test_points_far_behind_a_wall_are_strays_and_the_completion_is_cut_near_the_wall():
    # a cabinet seen from the room whose cloud carries 3% stray points 7 cm behind the y = 0 wall, its
    # generated mesh registered reaching as far: no point is seen behind a wall, so the mesh is cut within
    # 2 cm of it and the cabinet is not pushed 7 cm off its front
    rng = np.random.default_rng(4)
    front = np.c_[rng.uniform(1.5, 2.5, 800), np.full(800, 0.5), rng.uniform(0.0, 1.2, 800)]
    top = np.c_[rng.uniform(1.5, 2.5, 600), rng.uniform(0.0, 0.5, 600), np.full(600, 1.2)]
    strays = np.c_[rng.uniform(1.5, 2.5, 45), np.full(45, -0.07), rng.uniform(0.0, 1.2, 45)]
    cabinet = box_object(1, "cabinet", (1.0, 0.57, 1.2), placed(2.0, 0.215), exact_shape=False)
    cabinet = replace(cabinet, points=np.vstack([front, top, strays]))
    (cut,) = room_cuts(cabinet, room_from_shell(rect_room()))
    assert "wall" in cut.source
    assert cut.points_asset[0][1] + cabinet.world_from_asset[1, 3] >= -0.02 - 1e-9
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    layout = attach({InstanceId(1): cabinet}, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert layout.world_from_asset[InstanceId(1)][1, 3] - cabinet.world_from_asset[1, 3] <= 0.021


def _counter_and_cup(cup_points_low: float, cup_bottom: float = 0.87, counter_height: float = 0.9):
    """A generated counter 0.9 m tall seen from above (points on its top) and a cup 0.08 m tall on it whose
    generated mesh is 0.14 m tall, registered with its bottom at ``cup_bottom`` m (by default with 0.03 m of
    surplus below and above the cup's points); the cup's points reach down to ``cup_points_low`` m. The
    counter's generated mesh is ``counter_height`` m tall."""
    rng = np.random.default_rng(3)
    top = np.c_[rng.uniform(1.5, 2.5, 2000), rng.uniform(2.2, 2.8, 2000), rng.normal(0.9, 0.002, 2000)]
    counter = replace(
        box_object(1, "counter", (1.0, 0.6, counter_height), placed(2.0, 2.5), exact_shape=False), points=top
    )
    ring = rng.uniform(0.0, 2.0 * np.pi, 600)
    side = np.c_[2.0 + 0.04 * np.cos(ring), 2.5 + 0.04 * np.sin(ring), rng.uniform(cup_points_low, 0.98, 600)]
    cup = replace(
        box_object(2, "cup", (0.08, 0.08, 0.14), placed(2.0, 2.5, cup_bottom), exact_shape=False), points=side
    )
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.87),
        )
    )
    return {InstanceId(1): counter, InstanceId(2): cup}, graph


def test_a_childs_completion_taller_than_its_points_is_cut_where_they_end_and_seated_there():
    objects, graph = _counter_and_cup(0.9)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    cuts = [c for c in layout.completions()[InstanceId(2)] if c.kind is CompletionKind.CUT]
    assert len(cuts) == 2  # below the bottom and above the top the capture saw
    cup = visual_objects(objects, layout)[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])
    # on the counter's top where it was seen, not lifted 3 cm by the surplus below its points
    assert abs(cup[:, 2].min() - 0.9) < 0.005
    assert abs(cup[:, 2].max() - 0.98) < 0.005
    metrics = structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())
    assert metrics["support_contact_pass"] == 1.0


def test_a_child_seen_only_above_its_support_is_not_cut():
    # the cup's points end 5 cm above the counter (its rim seen over a bowl in front): its bottom was not seen
    objects, graph = _counter_and_cup(0.95)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    assert not [c for c in layout.completions().get(InstanceId(2), []) if c.kind is CompletionKind.CUT]


def test_a_childs_completion_registered_into_its_supports_seen_top_is_cut_there_not_lifted():
    # the mesh reaches 1 cm into the counter's top, seen at 0.90 m; the cup's lowest points are the counter's
    # bleed (down to 0.89 m), so they do not show where its bottom ends, but nothing inside the counter can
    # have been seen: the surplus is cut at the seen top and the cup keeps its registered height
    objects, graph = _counter_and_cup(0.89, cup_bottom=0.89)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    cuts = [c for c in layout.completions()[InstanceId(2)] if c.kind is CompletionKind.CUT]
    assert any("into the top its support was seen with" in c.source for c in cuts)
    cup = visual_objects(objects, layout)[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])
    assert abs(cup[:, 2].min() - 0.9) < 0.004  # on the seen top, not lifted 1 cm
    assert abs(cup[:, 2].max() - 0.98) < 0.005  # and ending where its points end
    metrics = structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())
    assert metrics["support_contact_pass"] == 1.0
    # the counter's completion 7 mm above its seen top: the cup stands on the top where its mesh was cut
    objects, graph = _counter_and_cup(0.89, cup_bottom=0.89, counter_height=0.907)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    cup = visual_objects(objects, layout)[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])
    assert abs(cup[:, 2].min() - 0.9) < 0.003
    # a few millimetres into the top is depth noise: no cut, the support rule seats it
    objects, graph = _counter_and_cup(0.897, cup_bottom=0.897)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    assert not [c for c in layout.completions().get(InstanceId(2), []) if c.kind is CompletionKind.CUT]


def test_a_child_registered_tilted_is_cut_as_it_will_stand_levelled_on_its_support():
    # a spice jar 7 cm tall seen upright on the counter (points 0.90-0.97 m) whose completion is 10 cm tall,
    # registered 34 deg tilted about the points' middle: levelled there, it reaches 1.5 cm into the counter
    # and 1.5 cm above its points; cut at the seen top and where its points end, it stands as it was seen
    from rescene_core.assembly.transforms import rotation_about

    objects, graph = _counter_and_cup(0.9)
    rng = np.random.default_rng(11)
    ring = rng.uniform(0.0, 2.0 * np.pi, 600)
    side = np.c_[2.0 + 0.025 * np.cos(ring), 2.5 + 0.025 * np.sin(ring), rng.uniform(0.9, 0.97, 600)]
    pose = rotation_about([0.6, 0.0, 0.0], [2.0, 2.5, 0.935]) @ placed(2.0, 2.5, 0.885)
    jar = replace(box_object(2, "spice jar", (0.05, 0.05, 0.10), pose, exact_shape=False), points=side)
    objects[InstanceId(2)] = jar
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    cuts = [c for c in layout.completions()[InstanceId(2)] if c.kind is CompletionKind.CUT]
    assert len(cuts) == 2
    seen = visual_objects(objects, layout)[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])
    assert np.ptp(seen[:, :2], axis=0).max() < 0.06  # upright
    assert abs(seen[:, 2].min() - 0.9) < 0.004 and abs(seen[:, 2].max() - 0.97) < 0.005
