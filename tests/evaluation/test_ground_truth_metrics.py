"""Metrics against ground truth: per-object centre error and chamfer, scene chamfer, graph accuracy."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.capture.ground_truth import GroundTruth, GtObject, GtRelation
from rescene_core.evaluation.ground_truth import GtEvaluationConfig, chamfer, graph_accuracy, gt_metrics
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph

SHELL = RoomShell(Plane((0.0, 0.0, 1.0), 0.0), (), ((-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)))


def _gt() -> GroundTruth:
    table = trimesh.creation.box(extents=[1.0, 0.6, 0.7])
    table.apply_translation([0, 0, 0.35])
    lamp = trimesh.creation.box(extents=[0.2, 0.2, 0.4])
    lamp.apply_translation([0, 0, 0.2])
    t_pose, l_pose = np.eye(4), np.eye(4)
    t_pose[:3, 3] = [1.0, 0.0, 0.0]
    l_pose[:3, 3] = [1.0, 0.0, 0.7]
    objects = (
        GtObject(1, "table", np.asarray(table.vertices), np.asarray(table.faces), t_pose, (11,)),
        GtObject(2, "lamp", np.asarray(lamp.vertices), np.asarray(lamp.faces), l_pose, (12, 13)),
    )
    relations = (GtRelation(1, Relation.RESTS_ON, Root.FLOOR), GtRelation(2, Relation.RESTS_ON, 1))
    return GroundTruth(objects, relations, SHELL)


def _placed(gt: GroundTruth, shift: float) -> tuple[dict, dict]:
    objects, poses = {}, {}
    for obj in gt.objects:
        m = np.array(obj.world_from_object)
        m[0, 3] += shift
        objects[obj.instance_ids[0]] = (obj.label, obj.vertices, obj.faces)
        poses[obj.instance_ids[0]] = m
    return objects, poses


def test_perfect_and_shifted_placement():
    gt = _gt()
    graph = SceneGraph(
        (Edge(InstanceId(11), Relation.RESTS_ON, Root.FLOOR), Edge(InstanceId(12), Relation.RESTS_ON, InstanceId(11)))
    )
    cfg = GtEvaluationConfig(object_samples=3000, scene_samples=6000)
    objects, exact = _placed(gt, 0.0)
    _, shifted = _placed(gt, 0.3)
    m = gt_metrics(objects, final_poses=exact, registered_poses=shifted, graph=graph, gt=gt, config=cfg)
    assert m["recall"] == 1.0 and m["objects_recalled"] == 2
    assert m["mean_final_centre_error"] == pytest.approx(0.0, abs=1e-9)
    assert m["mean_final_chamfer"] < 0.02 and m["scene_chamfer"] < 0.02
    assert m["mean_registered_centre_error"] == pytest.approx(0.3)
    assert m["mean_registered_chamfer"] > 0.1
    assert m["graph"]["edge_accuracy"] == 1.0 and m["graph"]["edge_precision"] == 1.0


def test_graph_accuracy_compares_parents_as_objects():
    gt = _gt()
    # the lamp (primary instance 12) names the right parent (the table's instance 11), the wrong relation
    graph = SceneGraph(
        (Edge(InstanceId(11), Relation.RESTS_ON, Root.FLOOR), Edge(InstanceId(12), Relation.MOUNTS_ON, InstanceId(11)))
    )
    acc = graph_accuracy(graph, gt)
    assert acc["gt_edges"] == 2 and acc["edge_accuracy"] == 0.5
    assert acc["parent_accuracy"] == 1.0 and acc["relation_accuracy"] == 0.5


def test_chamfer_of_identical_and_empty_sets():
    pts = np.random.default_rng(0).normal(size=(100, 3))
    assert chamfer(pts, pts) == 0.0
    assert np.isnan(chamfer(pts, np.zeros((0, 3))))
    assert chamfer(pts, pts + [0.5, 0, 0]) > 0.0
