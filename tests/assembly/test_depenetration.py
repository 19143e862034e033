"""Depenetration movers: support groups move together, wall mounts slide in their wall's plane."""

from __future__ import annotations

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.geometry.sim3 import inverse
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

CFG = AttachmentConfig(dual_attachment=False)


def test_a_lamp_pushed_by_a_cabinet_takes_its_table_along():
    shell = rect_room()
    table = box_object(1, "table", (1.0, 0.6, 0.75), placed(1.5, 2.5))
    # a generated lamp registered at the table's edge, overhanging it into the cabinet beside the table
    lamp = box_object(2, "table lamp", (0.3, 0.3, 0.4), placed(1.95, 2.5, 0.75), exact_shape=False)
    cabinet = box_object(3, "cabinet", (0.6, 0.6, 1.2), placed(2.36, 2.5))
    objects = {o.instance: o for o in (table, lamp, cabinet)}
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 1.0),
            Edge(InstanceId(3), Relation.RESTS_ON, Root.FLOOR, 1.0),
        )
    )
    assert structural_metrics(objects, None, graph, shell)["collision_pairs"] == 1
    layout = attach(objects, graph, shell, CFG)
    after = structural_metrics(objects, layout, graph, shell)
    assert after["collision_pairs"] == 0 and after["support_contact_pass"] == 1.0
    # the lamp did not slide on its table: the table moved with it
    pose = layout.world_from_asset
    relative_before = inverse(table.world_from_asset) @ lamp.world_from_asset
    relative_after = inverse(pose[InstanceId(1)]) @ pose[InstanceId(2)]
    assert np.allclose(relative_before, relative_after, atol=1e-6)
    assert np.linalg.norm(pose[InstanceId(1)][:3, 3] - table.world_from_asset[:3, 3]) > 0.02


def test_a_picture_hanging_into_a_cabinet_slides_up_its_wall():
    shell = rect_room()  # wall 0 is y = 0, normal +y
    cabinet = box_object(1, "cabinet", (0.8, 0.5, 0.8), placed(2.0, 0.25))
    picture = box_object(2, "picture", (0.7, 0.03, 0.5), placed(2.0, 0.015, 0.7))  # bottom 0.70, cabinet top 0.80
    objects = {o.instance: o for o in (cabinet, picture)}
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.MOUNTS_ON, Root.WALL, 1.0, wall_id=0),
        )
    )
    assert structural_metrics(objects, None, graph, shell)["collision_pairs"] == 1
    layout = attach(objects, graph, shell, CFG)
    after = structural_metrics(objects, layout, graph, shell)
    assert after["collision_pairs"] == 0
    assert after["wall_contact_pass"] == 1.0 and after["floor_contact_pass"] == 1.0
    moves = [op for op in layout.operations if op["stage"] == "depenetration" and op["instance"] == 2]
    assert moves
    for op in moves:  # in the wall's plane (x along the wall, z up), never off the wall
        t = np.asarray(op["transform"])[:3, 3]
        assert abs(t[1]) < 1e-9 and t[2] > 0.0


def test_a_nightstand_jammed_against_a_wall_makes_the_bed_move():
    shell = rect_room()  # wall 3 is x = 0
    bed = box_object(1, "bed", (1.6, 2.0, 0.5), placed(1.25, 2.5))  # x 0.45 .. 2.05
    nightstand = box_object(2, "nightstand", (0.5, 0.4, 0.55), placed(0.3, 2.5))  # x 0.05 .. 0.55: 0.1 into the bed
    objects = {o.instance: o for o in (bed, nightstand)}
    graph = SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR, 1.0) for i in (1, 2)))
    assert structural_metrics(objects, None, graph, shell)["collision_pairs"] == 1
    layout = attach(
        objects, graph, shell, AttachmentConfig(dual_attachment=False, near_wall_snap=False, bed_wall=False)
    )
    after = structural_metrics(objects, layout, graph, shell)
    assert after["collision_pairs"] == 0 and after["oob_count"] == 0
    assert layout.world_from_asset[InstanceId(1)][0, 3] > bed.world_from_asset[0, 3] + 0.05


def test_a_picture_just_under_a_shelf_is_parted_in_the_wall_plane_not_slid_sideways():
    shell = rect_room()  # wall 0 is y = 0, normal +y
    shelf = box_object(1, "wall shelf", (0.8, 0.25, 0.2), placed(2.0, 0.125, 1.45))
    picture = box_object(2, "picture", (0.7, 0.03, 0.5), placed(2.0, 0.015, 0.97))  # top 1.47, shelf bottom 1.45
    objects = {o.instance: o for o in (shelf, picture)}
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.MOUNTS_ON, Root.WALL, 1.0, wall_id=0),
            Edge(InstanceId(2), Relation.MOUNTS_ON, Root.WALL, 1.0, wall_id=0),
        )
    )
    assert structural_metrics(objects, None, graph, shell)["collision_pairs"] == 1
    layout = attach(objects, graph, shell, CFG)
    after = structural_metrics(objects, layout, graph, shell)
    assert after["collision_pairs"] == 0 and after["wall_contact_pass"] == 1.0
    for i, obj in objects.items():  # parted by centimetres, not by a picture's width along the wall
        assert np.linalg.norm(layout.world_from_asset[i][:3, 3] - obj.world_from_asset[:3, 3]) < 0.05


def test_a_board_reaching_just_into_the_next_counter_top_is_lifted_onto_it_not_pushed():
    shell = rect_room()
    counter = box_object(1, "kitchen counter", (1.0, 0.6, 0.9), placed(1.5, 2.5))  # x 1.0 .. 2.0
    # the next counter, registered 2 mm taller, 4 mm along the row
    neighbour = box_object(2, "kitchen counter", (0.6, 0.6, 0.902), placed(2.304, 2.5))  # x 2.004 .. 2.604
    # a generated board on 1, its centre on 1 (x 1.75 .. 2.15)
    board = box_object(3, "cutting board", (0.4, 0.3, 0.02), placed(1.95, 2.5, 0.9), exact_shape=False)
    objects = {o.instance: o for o in (counter, neighbour, board)}
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(1), 1.0),
        )
    )
    assert structural_metrics(objects, None, graph, shell)["collision_pairs"] == 1
    cfg = AttachmentConfig(dual_attachment=False, near_wall_snap=False, restore_toward_evidence=False)
    layout = attach(objects, graph, shell, cfg)
    assert structural_metrics(objects, layout, graph, shell)["collision_pairs"] == 0
    pose = layout.world_from_asset
    for i, obj in ((1, counter), (2, neighbour)):  # neither counter pushed along the row
        assert np.linalg.norm(pose[InstanceId(i)][:2, 3] - obj.world_from_asset[:2, 3]) < 1e-6
    lift = pose[InstanceId(3)][2, 3] - board.world_from_asset[2, 3]
    assert 0.002 < lift <= 0.004  # onto the neighbour's top, a millimetre clear of it
    np.testing.assert_allclose(pose[InstanceId(3)][:2, 3], board.world_from_asset[:2, 3], atol=1e-6)
    assert any(op["rule"] == "lift onto neighbour's top" for op in layout.operations)
