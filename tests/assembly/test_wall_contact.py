"""Wall contact of generated objects decided by their observed points (``assembly/wall_evidence.py``): the
side that faces the wall, a turn beyond the yaw limit where the registration turned the object, and
points that contradict the edge."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import trimesh

from rescene_core.assembly import AssemblyObject, attach
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.assembly.transforms import nearest_axis, signed_yaw
from rescene_core.assembly.wall_evidence import turn_to_wall_evidence
from rescene_core.bench.assembly import metric_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

WALL_NORMAL = np.array([0.0, 1.0, 0.0])
"""Wall 0 of ``rect_room`` is the plane y = 0, its normal +y into the room."""


def _picture(rng, registered_yaw_deg: float, points_y: float = 0.015, confidence: float = 0.9):
    """A 0.6 x 0.03 x 0.45 m picture on wall 0 at x = 2, seen as a flat, noisy sheet of points; its generated
    slab registered at the points' centre but turned ``registered_yaw_deg`` (90: edge-on to the wall)."""
    pts = np.c_[rng.uniform(1.7, 2.3, 3000), points_y + rng.normal(0.0, 0.03, 3000), rng.uniform(1.5, 1.95, 3000)]
    obj = box_object(1, "picture", (0.6, 0.03, 0.45), placed(2.0, points_y, 1.5, registered_yaw_deg), exact_shape=False)
    obj = replace(obj, points=pts)
    graph = SceneGraph((Edge(InstanceId(1), Relation.MOUNTS_ON, Root.WALL, confidence, wall_id=0),))
    return {obj.instance: obj}, graph, rect_room()


def _bevelled_shelf(rng, registered_yaw_deg: float = 20.0):
    """A 0.4 x 0.4 x 0.2 m wall shelf on wall 0 at x = 2, z 1.4-1.6, seen on its front, top and bottom.
    Its generated mesh is the box with its vertical edges bevelled at 45 deg (13 cm chamfers, as marching
    cubes bevels a small object), so the bevels hold more vertical area than any pair of sides; registered
    ``registered_yaw_deg`` off the wall at the points' centre."""
    h, c = 0.2, 0.13
    octagon = [(sx * h, sy * (h - c)) for sx in (-1, 1) for sy in (-1, 1)]
    octagon += [(sx * (h - c), sy * h) for sx in (-1, 1) for sy in (-1, 1)]
    hull = trimesh.convex.convex_hull(np.array([(x, y, z) for x, y in octagon for z in (0.0, 0.2)]))
    front = np.c_[rng.uniform(1.8, 2.2, 1500), np.full(1500, 0.4), rng.uniform(1.4, 1.6, 1500)]
    top = np.c_[rng.uniform(1.8, 2.2, 1500), rng.uniform(0.0, 0.4, 1500), np.full(1500, 1.6)]
    bottom = np.c_[rng.uniform(1.8, 2.2, 800), rng.uniform(0.0, 0.4, 800), np.full(800, 1.4)]
    pts = np.vstack([front, top, bottom]) + rng.normal(0.0, 0.005, (3800, 3))
    obj = AssemblyObject(
        InstanceId(1),
        "wall shelf",
        np.asarray(hull.vertices, np.float64),
        np.asarray(hull.faces, np.int64),
        placed(2.0, 0.2, 1.4, registered_yaw_deg),
        exact_shape=False,
        points=pts,
    )
    graph = SceneGraph((Edge(InstanceId(1), Relation.MOUNTS_ON, Root.WALL, 0.98, wall_id=0),))
    return {obj.instance: obj}, graph, rect_room()


def _wall_pass(objects, graph, shell, config: AttachmentConfig) -> tuple[bool, float]:
    """(wall contact passes, angle in deg between the asset axis nearest the wall normal and the normal)."""
    layout = attach(objects, graph, shell, config)
    metrics = structural_metrics(metric_objects(objects, layout), layout, graph, shell)
    pose = layout.world_from_asset[InstanceId(1)]
    _, _, axis = nearest_axis(pose, WALL_NORMAL, (0, 1))
    return metrics["wall_contact_pass"] == 1.0, abs(np.degrees(signed_yaw(axis, WALL_NORMAL, np.array([0, 0, 1.0]))))


def test_picture_registered_edge_on_is_turned_flat_onto_its_wall():
    objects, graph, shell = _picture(np.random.default_rng(0), registered_yaw_deg=70.0)
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig())
    assert ok and angle < 1.0
    # the turn is the points' doing: without it the 70 deg error is beyond the paper's 35 deg yaw limit
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig(wall_evidence_turn_min_gain=None))
    assert not ok and angle > 5.0


def test_turn_beyond_the_limit_is_logged_and_only_for_confident_edges():
    objects, graph, shell = _picture(np.random.default_rng(1), registered_yaw_deg=75.0)
    layout = attach(objects, graph, shell, AttachmentConfig())
    turns = [op for op in layout.operations if op["stage"] == "wall evidence"]
    assert len(turns) == 1 and turns[0]["wall_id"] == 0
    assert abs(abs(turns[0]["yaw_deg"]) - 75.0) < 1.0 and turns[0]["fit_turned"] > turns[0]["fit_within_limit"]
    weak = SceneGraph((replace(graph.edges[0], confidence=0.5),))
    out, done = turn_to_wall_evidence(objects, weak, room_from_shell(shell), AttachmentConfig())
    assert done == [] and out[InstanceId(1)] is objects[InstanceId(1)]


def test_picture_turned_within_the_limit_keeps_its_usual_turn():
    # a 20 deg registration error is the wall rule's to square (no turn before the rules)
    objects, graph, shell = _picture(np.random.default_rng(2), registered_yaw_deg=20.0)
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert not [op for op in layout.operations if op["stage"] == "wall evidence"]
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig())
    assert ok and angle < 5.0


def test_bevelled_shelf_hangs_by_the_side_its_points_show_not_its_bevels():
    objects, graph, shell = _bevelled_shelf(np.random.default_rng(3))
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig())
    assert ok and angle < 1.0
    layout = attach(objects, graph, shell, AttachmentConfig())
    (op,) = [op for op in layout.operations if op["stage"] == "wall attachment" and op["rule"] != "skip"]
    assert op["side_from_points"].startswith("asset axis") and op["side_fit"] > op["faces_fit"]
    # the dominant face direction alone squares a bevel to the wall: the shelf hangs 45 deg off it
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig(wall_side_min_gain=None))
    assert not ok and abs(angle - 45.0) < 5.0


def test_points_far_from_the_wall_contradict_the_edge_and_keep_the_registered_pose():
    # the capture saw the 'picture' 1.2 m into the room: the mounts-on wall edge is wrong. Registered edge-on,
    # its slab explains few of its points anywhere, so the bound on the points' share does not refuse the move
    objects, graph, shell = _picture(np.random.default_rng(4), registered_yaw_deg=90.0, points_y=1.2)
    layout = attach(objects, graph, shell, AttachmentConfig(dual_attachment=False))
    pose = layout.world_from_asset[InstanceId(1)]
    np.testing.assert_allclose(pose, objects[InstanceId(1)].world_from_asset, atol=1e-9)
    skips = [op for op in layout.operations if op["stage"] == "wall attachment" and op["rule"] == "skip"]
    assert len(skips) == 1 and "contradict the mounts-on wall edge" in skips[0]["reason"]
    # without the check (and without the correction bound) the wall rule pulls it 1.2 m onto the wall
    cfg = AttachmentConfig(dual_attachment=False, wall_points_max_gap=None, max_correction_m=None)
    layout = attach(objects, graph, shell, cfg)
    pulled = objects[InstanceId(1)].world_vertices(layout.world_from_asset[InstanceId(1)])
    assert pulled[:, 1].min() < 0.05
    # the correction bound alone refuses that pull (cut short, a wall contact is none) and says so
    cfg = AttachmentConfig(dual_attachment=False, wall_points_max_gap=None, stop_after="relations")
    layout = attach(objects, graph, shell, cfg)
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(1)], objects[InstanceId(1)].world_from_asset)
    (op,) = [op for op in layout.operations if op["stage"] == "wall attachment" and "bound_clipped" in op]
    assert op["rule"] == "skip" and "max_correction_m" in op["reason"]
    assert op["bound_clipped"]["wanted_m"] > 0.85 and op["bound_clipped"]["taken_m"] == 0.0


def test_objects_without_points_keep_the_face_direction_rule():
    objects, graph, shell = _bevelled_shelf(np.random.default_rng(5))
    bare = {i: replace(o, points=None) for i, o in objects.items()}
    with_rule = attach(bare, graph, shell, AttachmentConfig()).world_from_asset[InstanceId(1)]
    without = attach(bare, graph, shell, AttachmentConfig(wall_side_min_gain=None)).world_from_asset[InstanceId(1)]
    np.testing.assert_allclose(with_rule, without, atol=1e-12)


def test_a_shelf_registered_rolled_about_its_long_axis_is_levelled_by_its_own_up_axis():
    # a 0.9 x 0.25 x 0.18 m generated wall shelf (its frame z-up, as both generators make it) registered
    # rolled 48 deg about its long axis (x): past the 45 deg levelling limit of the nearest axis
    from rescene_core.assembly.transforms import rotation_about

    rng = np.random.default_rng(5)
    pts = np.c_[rng.uniform(1.55, 2.45, 3000), rng.uniform(0.0, 0.25, 3000), rng.uniform(1.5, 1.68, 3000)]
    rolled = placed(2.0, 0.14, 1.59) @ rotation_about([np.radians(48.0), 0.0, 0.0], [0.0, 0.0, 0.0])
    obj = replace(box_object(1, "wall shelf", (0.9, 0.25, 0.18), rolled, exact_shape=False), points=pts)
    graph = SceneGraph((Edge(InstanceId(1), Relation.MOUNTS_ON, Root.WALL, 0.63, wall_id=0),))
    objects, shell = {obj.instance: obj}, rect_room()
    layout = attach(objects, graph, shell, AttachmentConfig())
    pose = layout.world_from_asset[InstanceId(1)]
    np.testing.assert_allclose(pose[:3, 2] / np.linalg.norm(pose[:3, 2]), [0.0, 0.0, 1.0], atol=1e-6)
    ok, angle = _wall_pass(objects, graph, shell, AttachmentConfig())
    assert ok and angle < 1.0
    assert abs(np.ptp(obj.world_vertices(pose)[:, 2]) - 0.18) < 1e-6  # its own height, not a 48 deg diagonal


def _board_on_counter(rng, upright: bool):
    """A cutting board 0.4 x 0.24 m at x = 2 whose back edge is 3 cm off wall 0, on a counter 0.9 m tall seen
    from above against that wall, answered ``mounts-on wall``: lying flat (2 cm tall) on the counter's top,
    or standing upright on it (0.24 m tall, 2 cm deep)."""
    worktop = np.c_[rng.uniform(1.5, 2.5, 800), rng.uniform(0.0, 0.6, 800), 0.9 + rng.normal(0.0, 0.001, 800)]
    counter = box_object(1, "kitchen counter", (1.0, 0.6, 0.9), placed(2.0, 0.3), exact_shape=False)
    counter = replace(counter, points=worktop)
    size = (0.4, 0.02, 0.24) if upright else (0.4, 0.24, 0.02)
    board = box_object(2, "cutting board", size, placed(2.0, 0.03 + size[1] / 2, 0.9), exact_shape=False)
    lo = np.array([1.8, 0.03, 0.9])
    board = replace(board, points=lo + rng.uniform(0.0, 1.0, (400, 3)) * np.array(size))
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.MOUNTS_ON, Root.WALL, 0.73, wall_id=0),
        )
    )
    return {InstanceId(1): counter, InstanceId(2): board}, graph


def test_a_board_lying_flat_on_a_counter_is_not_pulled_onto_the_wall_and_an_upright_one_is():
    rng = np.random.default_rng(5)
    objects, graph = _board_on_counter(rng, upright=False)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    moved = layout.world_from_asset[InstanceId(2)][:3, 3] - objects[InstanceId(2)].world_from_asset[:3, 3]
    assert np.linalg.norm(moved) < 1e-9  # it lies where it was seen
    skips = [op for op in layout.operations if op["instance"] == 2 and op["rule"] == "skip"]
    assert any("lie flat" in str(op["reason"]) and "object 1" in str(op["reason"]) for op in skips)
    # standing on its edge against the backsplash, it leans on the wall: mounted there
    objects, graph = _board_on_counter(rng, upright=True)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    board = objects[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])
    assert board[:, 1].min() < 0.005
