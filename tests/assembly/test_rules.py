"""Each attachment rule does what the paper's dispatch table says, on the hand-built bedroom."""

from __future__ import annotations

import numpy as np
import pytest

from rescene_core.assembly import attach
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.transforms import rotation_about, translation
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
from tests.assembly.helpers import moved, scene

CFG = AttachmentConfig()


def test_ground_truth_layout_is_left_alone():
    objects, graph, shell = scene()
    layout = attach(objects, graph, shell, CFG)
    for i, obj in objects.items():
        np.testing.assert_allclose(layout.world_from_asset[i], obj.world_from_asset, atol=1e-9)
    metrics = structural_metrics(objects, layout, graph, shell)
    assert metrics["collision_pairs"] == 0 and metrics["oob_count"] == 0


@pytest.mark.parametrize("dz", [0.3, -0.12, 1.2])
def test_floor_snap_lands_within_contact_gap(dz):
    objects, graph, shell = scene()
    tilt = rotation_about([np.radians(8.0), 0.0, 0.0], [2.0, 4.0, 0.25])
    objects = moved(objects, 1, translation([0.0, 0.0, dz]) @ tilt)
    layout = attach(objects, graph, shell, CFG)
    verts = objects[InstanceId(1)].world_vertices(layout.world_from_asset[InstanceId(1)])
    assert abs(verts[:, 2].min()) <= CFG.contact_gap
    # levelled: the box's top face is horizontal again
    assert np.ptp(np.sort(verts[:, 2])[-4:]) < 1e-6


def test_floor_snap_respects_its_vertical_limit():
    objects, graph, shell = scene()
    objects = moved(objects, 6, translation([0.0, 0.0, 2.0]))
    cfg = AttachmentConfig(stop_after="relations", dual_attachment=False)
    layout = attach(objects, graph, shell, cfg)
    z = objects[InstanceId(6)].world_vertices(layout.world_from_asset[InstanceId(6)])[:, 2].min()
    assert z == pytest.approx(2.0 - cfg.max_floor_snap)


def test_floor_snap_projects_footprint_into_the_room():
    objects, graph, shell = scene()
    objects = moved(objects, 6, translation([0.5, -0.4, 0.1]))  # through the south-east corner
    layout = attach(objects, graph, shell, AttachmentConfig(stop_after="relations"))
    verts = objects[InstanceId(6)].world_vertices(layout.world_from_asset[InstanceId(6)])
    # the smallest step inside: the footprint ends at the contact gap, not at the collision margin
    assert verts[:, 0].max() == pytest.approx(4.0 - CFG.wall_contact_gap, abs=1e-6)
    assert verts[:, 1].min() == pytest.approx(CFG.wall_contact_gap, abs=1e-6)


def test_wall_mount_makes_back_coplanar_and_parallel():
    objects, graph, shell = scene()
    turn = rotation_about([0.0, 0.0, np.radians(20.0)], [1.6, 4.9, 1.45])
    objects = moved(objects, 4, translation([0.0, -0.25, 0.05]) @ turn)
    layout = attach(objects, graph, shell, CFG)
    pose = layout.world_from_asset[InstanceId(4)]
    verts = objects[InstanceId(4)].world_vertices(pose)
    assert verts[:, 1].max() == pytest.approx(5.0, abs=1e-6)  # back on the north wall plane y = 5
    back = -pose[:3, 1] / np.linalg.norm(pose[:3, 1])  # asset -y is the back
    assert back @ np.array([0.0, 1.0, 0.0]) == pytest.approx(1.0, abs=1e-9)
    assert structural_metrics(objects, layout, graph, shell)["wall_contact_pass"] == 1.0


def test_wall_yaw_limit_skips_a_wall_too_far_turned():
    objects, graph, shell = scene()
    turn = rotation_about([0.0, 0.0, np.radians(44.0)], [1.6, 4.9, 1.45])
    objects = moved(objects, 4, translation([0.0, -0.6, 0.0]) @ turn)
    layout = attach(objects, graph, shell, AttachmentConfig(max_wall_yaw_deg=10.0, stop_after="relations"))
    skips = [op for op in layout.operations if op["instance"] == 4 and op["rule"] == "skip"]
    assert any("yaw limit" in op["reason"] for op in skips)


def test_lateral_order_on_a_wall_is_kept():
    objects, graph, shell = scene()
    # both pictures pushed past the west end of the north wall, in order 4 (x=-0.5) then 5 (x=-0.2)
    objects = moved(objects, 4, translation([-2.1, -0.1, 0.0]))
    objects = moved(objects, 5, translation([-2.8, -0.1, 0.0]))
    layout = attach(objects, graph, shell, CFG)
    x4 = layout.world_from_asset[InstanceId(4)][0, 3]
    x5 = layout.world_from_asset[InstanceId(5)][0, 3]
    assert x4 < x5
    assert structural_metrics(objects, layout, graph, shell)["collision_pairs"] == 0
    for i in (4, 5):
        verts = objects[InstanceId(i)].world_vertices(layout.world_from_asset[InstanceId(i)])
        assert verts[:, 0].min() >= CFG.wall_corner_margin - 1e-6


def test_object_support_puts_child_on_parent_top():
    objects, graph, shell = scene()
    objects = moved(objects, 3, translation([0.15, 0.05, 0.4]))
    layout = attach(objects, graph, shell, CFG)
    verts = objects[InstanceId(3)].world_vertices(layout.world_from_asset[InstanceId(3)])
    assert verts[:, 2].min() == pytest.approx(0.55, abs=1e-6)
    assert structural_metrics(objects, layout, graph, shell)["support_contact_pass"] == 1.0


def test_support_levels_find_shelves():
    import trimesh

    from rescene_core.assembly.compile_support import support_levels_of

    boards = [trimesh.creation.box(extents=(0.8, 0.3, 0.02)) for _ in range(3)]
    for k, b in enumerate(boards):
        b.apply_translation([0, 0, 0.4 * k + 0.01])
    shelf = trimesh.util.concatenate(boards)
    _, _, shell = scene()
    levels = support_levels_of(shelf.vertices, shelf.faces, room_from_shell(shell), 10.0, 0.01)
    assert [round(lv.height, 3) for lv in levels] == [0.82, 0.42, 0.02]


def test_depenetration_separates_interpenetrating_pair():
    objects, graph, shell = scene()
    objects = moved(objects, 2, translation([0.35, -0.1, 0.0]))  # nightstand pushed into the bed
    before = structural_metrics(objects, None, graph, shell)
    assert before["collision_pairs"] >= 1
    layout = attach(objects, graph, shell, CFG)
    after = structural_metrics(objects, layout, graph, shell)
    assert after["collision_pairs"] == 0
    assert after["oob_count"] == 0
    # the lamp went along with its nightstand
    assert after["support_contact_pass"] == 1.0
    rules = {op["stage"] for op in layout.operations}
    assert "depenetration" in rules


def test_outside_repair_brings_object_back_through_the_wall():
    objects, graph, shell = scene()
    objects = moved(objects, 1, translation([0.0, 0.6, 0.0]))  # bed pushed through the north wall
    graph = SceneGraph(tuple(e for e in graph.edges if e.child != 1))  # no edge: only repairs can fix it
    layout = attach(objects, graph, shell, CFG)
    metrics = structural_metrics(objects, layout, graph, shell)
    assert metrics["oob_count"] == 0
    assert any(op["stage"] == "outside repair" and op["instance"] == 1 for op in layout.operations)


def test_operations_name_object_rule_and_transform():
    objects, graph, shell = scene()
    objects = moved(objects, 2, translation([0.0, 0.0, 0.2]))
    layout = attach(objects, graph, shell, CFG)
    ops = [op for op in layout.operations if op["instance"] == 2 and op["stage"] == "floor snap"]
    assert ops and all({"rule", "transform", "branch", "omega"} <= set(op) for op in ops)
    assert np.asarray(ops[0]["transform"]).shape == (4, 4)


def test_new_relation_type_is_one_row():
    from rescene_core.assembly import dispatch

    objects, graph, shell = scene()
    graph = SceneGraph(tuple(Edge(e.child, Relation.MOUNTS_ON, Root.FLOOR) if e.child == 6 else e for e in graph.edges))
    layout = attach(objects, graph, shell, AttachmentConfig(stop_after="relations"))
    assert any(op["instance"] == 6 and "no rule" in op.get("reason", "") for op in layout.operations)
    key = (Relation.MOUNTS_ON, "floor")
    dispatch.DISPATCH[key] = dispatch.DISPATCH[(Relation.RESTS_ON, "floor")]
    try:
        objects2 = moved(objects, 6, translation([0.0, 0.0, 0.3]))
        layout = attach(objects2, graph, shell, AttachmentConfig(stop_after="relations"))
        z = objects2[InstanceId(6)].world_vertices(layout.world_from_asset[InstanceId(6)])[:, 2].min()
        assert abs(z) < 1e-9
    finally:
        del dispatch.DISPATCH[key]
