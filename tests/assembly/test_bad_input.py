"""Bad input gives a clear error or a recorded skip, never a crash or an object thrown out of the room."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rescene_core.assembly import AssemblyError, attach
from rescene_core.assembly.scenes import box_object, placed
from rescene_core.assembly.transforms import translation
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import Edge, InstanceId, Plane, Relation, Root, SceneGraph
from tests.assembly.helpers import moved, scene

CFG = AttachmentConfig()


def skipped(layout, instance):
    return [op for op in layout.operations if op["instance"] == instance and op["rule"] in ("skip", "skip edge")]


def test_cycle_is_skipped_and_recorded():
    objects, graph, shell = scene()
    edges = [e for e in graph.edges if e.child not in (2, 3)]
    edges += [
        Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(3)),
        Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(2)),
    ]
    layout = attach(objects, SceneGraph(tuple(edges)), shell, CFG)
    assert set(layout.world_from_asset) == set(objects)
    assert any("cycle" in op["reason"] for op in skipped(layout, 2) + skipped(layout, 3))


def test_dangling_parent_is_skipped_and_recorded():
    objects, graph, shell = scene()
    edges = [*graph.edges, Edge(InstanceId(7), Relation.RESTS_ON, InstanceId(99))]
    edges = [e if e.child != 3 else Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(42)) for e in edges]
    objects = moved(objects, 3, translation([0.0, 0.0, 0.2]))
    layout = attach(objects, SceneGraph(tuple(edges)), shell, CFG)
    assert any("dangling" in op["reason"] for op in skipped(layout, 3))
    assert any("not an object" in op["reason"] for op in skipped(layout, 7))


def test_non_watertight_mesh_is_placed():
    objects, graph, shell = scene()
    bed = objects[InstanceId(1)]
    open_bed = replace(bed, faces=bed.faces[:-2], world_from_asset=translation([0, 0, 0.3]) @ bed.world_from_asset)
    assert not open_bed.mesh().is_watertight
    objects = {**objects, InstanceId(1): open_bed}
    layout = attach(objects, graph, shell, CFG)
    z = open_bed.world_vertices(layout.world_from_asset[InstanceId(1)])[:, 2].min()
    assert abs(z) <= CFG.contact_gap


def test_object_larger_than_room_is_left_in_place():
    objects, graph, shell = scene()
    huge = box_object(8, "rug", (6.0, 7.0, 0.02), placed(2.0, 2.5, 0.1))
    objects = {**objects, huge.instance: huge}
    graph = SceneGraph((*graph.edges, Edge(InstanceId(8), Relation.RESTS_ON, Root.FLOOR)))
    layout = attach(objects, graph, shell, CFG)
    pose = layout.world_from_asset[InstanceId(8)]
    assert pose[:2, 3] == pytest.approx([2.0, 2.5])  # not thrown anywhere
    assert any(
        "does not fit" in op.get("footprint", "") or "larger than the room" in op.get("reason", "")
        for op in layout.operations
        if op["instance"] == 8
    )
    # the other objects still end up inside and apart
    metrics = structural_metrics(objects, layout, graph, shell)
    assert metrics["oob_objects"] == [8]


def test_room_without_walls_skips_wall_rules():
    objects, graph, shell = scene()
    shell = replace(shell, walls=())
    objects = moved(objects, 4, translation([0.0, -0.2, 0.0]))
    layout = attach(objects, graph, shell, CFG)
    notes = [op["reason"] for op in layout.operations if op["rule"] == "note"]
    assert any("no usable walls" in n for n in notes)
    assert set(layout.world_from_asset) == set(objects)
    metrics = structural_metrics(objects, layout, graph, shell)
    assert metrics["oob_count"] == 0


def test_room_without_polygon_still_snaps_to_floor():
    objects, graph, shell = scene()
    shell = replace(shell, floor_polygon=())
    objects = moved(objects, 6, translation([0.0, 0.0, 0.3]))
    layout = attach(objects, graph, shell, CFG)
    assert objects[InstanceId(6)].world_vertices(layout.world_from_asset[InstanceId(6)])[:, 2].min() == pytest.approx(
        0.0
    )


def test_invalid_pose_or_mesh_becomes_missing():
    objects, graph, shell = scene()
    bad_pose = np.eye(4)
    bad_pose[0, 0] = np.nan
    objects = {
        **objects,
        InstanceId(2): replace(objects[InstanceId(2)], world_from_asset=bad_pose),
        InstanceId(5): replace(objects[InstanceId(5)], faces=np.zeros((0, 3), np.int64)),
    }
    layout = attach(objects, graph, shell, CFG)
    assert {int(m.instance) for m in layout.missing} == {2, 5}
    assert InstanceId(2) not in layout.world_from_asset
    # the lamp on the missing nightstand is kept, its edge recorded as dangling
    assert InstanceId(3) in layout.world_from_asset
    assert any("dangling" in op["reason"] for op in skipped(layout, 3))


def test_unusable_floor_is_a_clear_error():
    objects, graph, shell = scene()
    with pytest.raises(AssemblyError, match="floor"):
        attach(objects, graph, replace(shell, floor=Plane((0.0, 0.0, float("nan")), 0.0)), CFG)
    with pytest.raises(AssemblyError, match="z-up"):
        attach(objects, graph, replace(shell, floor=Plane((1.0, 0.0, 0.0), 0.0)), CFG)
