"""Ground truth: round trip through the capture's gt/ group, instance mapping, graph over instances."""

from __future__ import annotations

import numpy as np
import trimesh

from rescene_core.capture import open_capture, write_capture
from rescene_core.capture.ground_truth import (
    GroundTruth,
    GtObject,
    GtRelation,
    GtStructure,
    read_ground_truth,
    read_object_id_frames,
    write_ground_truth,
)
from rescene_core.records import Plane, Relation, RoomShell, Root, WallPlane
from tests.capture.toy import toy_capture_arrays


def _box(extents, z_lift=True):
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation([0, 0, extents[2] / 2])
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def _pose(x, y, z, yaw=0.0):
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.eye(4)
    out[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    out[:3, 3] = [x, y, z]
    return out


def small_gt() -> GroundTruth:
    table_v, table_f = _box((1.0, 0.6, 0.75))
    lamp_v, lamp_f = _box((0.2, 0.2, 0.4))
    book_v, book_f = _box((0.2, 0.15, 0.05))
    pic_v, pic_f = _box((0.5, 0.03, 0.4))
    shell = RoomShell(
        floor=Plane((0.0, 0.0, 1.0), 0.0),
        walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (4.0, 0.0))),),
        floor_polygon=((0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)),
        ceiling_height=2.6,
    )
    objects = (
        GtObject(1, "dining table", table_v, table_f, _pose(2, 1.5, 0, 0.3), (12,)),
        GtObject(2, "table lamp", lamp_v, lamp_f, _pose(2, 1.5, 0.75), (15, 16)),
        GtObject(3, "book stack", book_v, book_f, _pose(2.3, 1.5, 0.75), ()),
        GtObject(4, "picture", pic_v, pic_f, _pose(1, 0.0, 1.2), (14,)),
    )
    relations = (
        GtRelation(1, Relation.RESTS_ON, Root.FLOOR),
        GtRelation(2, Relation.RESTS_ON, 1),
        GtRelation(3, Relation.RESTS_ON, 1),
        GtRelation(4, Relation.MOUNTS_ON, Root.WALL, wall_id=0),
    )
    structure = (GtStructure(1, "floor"), GtStructure(2, "wall", 0))
    return GroundTruth(objects, relations, shell, structure)


def test_round_trip_through_capture(tmp_path):
    gt = small_gt()
    arrays = toy_capture_arrays()
    obj_ids = np.zeros(arrays.instance_masks.shape, np.int32)
    obj_ids[:, 2:4, 2:4] = 1
    path = write_capture(tmp_path / "c.zarr", arrays, extra=lambda root: write_ground_truth(root, gt, obj_ids))
    capture = open_capture(path)
    back = read_ground_truth(capture)
    assert back is not None
    assert back.shell == gt.shell
    assert back.relations == gt.relations
    assert back.structure == gt.structure
    for a, b in zip(gt.objects, back.objects):
        assert a.object_id == b.object_id and a.label == b.label and a.instance_ids == b.instance_ids
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
        np.testing.assert_array_equal(a.world_from_object, b.world_from_object)
    np.testing.assert_array_equal(read_object_id_frames(capture)[...], obj_ids)


def test_capture_without_gt_reads_none(tmp_path):
    path = write_capture(tmp_path / "c.zarr", toy_capture_arrays())
    assert read_ground_truth(open_capture(path)) is None
    assert read_object_id_frames(open_capture(path)) is None


def test_object_of_instance_covers_splits_and_skips_misses():
    gt = small_gt()
    assert gt.object_of_instance() == {12: 1, 15: 2, 16: 2, 14: 4}
    assert gt.primary_instance() == {1: 12, 2: 15, 4: 14}


def test_graph_by_instance_uses_primary_instances_and_drops_missed():
    graph = small_gt().graph_by_instance()
    assert graph.check() == []
    by_child = graph.parent_of()
    assert set(by_child) == {12, 15, 14}
    assert by_child[15].parent == 12 and by_child[15].relation == Relation.RESTS_ON
    assert by_child[12].parent == Root.FLOOR
    assert by_child[14].parent == Root.WALL and by_child[14].wall_id == 0


def test_graph_drops_descendants_of_a_missed_object():
    gt = small_gt()
    objects = tuple(
        GtObject(
            o.object_id, o.label, o.vertices, o.faces, o.world_from_object, () if o.object_id == 1 else o.instance_ids
        )
        for o in gt.objects
    )
    graph = GroundTruth(objects, gt.relations, gt.shell).graph_by_instance()
    assert graph.check() == []
    assert set(graph.parent_of()) == {14}


def test_world_mesh_is_posed():
    gt = small_gt()
    mesh = gt.world_mesh(2)
    assert isinstance(mesh, trimesh.Trimesh)
    np.testing.assert_allclose(mesh.bounds[0], [1.9, 1.4, 0.75])
    np.testing.assert_allclose(mesh.bounds[1], [2.1, 1.6, 1.15])
    assert mesh.is_watertight
