"""Dual attachment: which branch each group keeps."""

from __future__ import annotations

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.transforms import translation
from rescene_core.config import AttachmentConfig
from rescene_core.records import Edge, InstanceId, SceneGraph
from tests.assembly.helpers import moved, scene


def test_low_confidence_wall_edge_keeps_floor_only():
    objects, graph, shell = scene()
    objects = moved(objects, 4, translation([0.0, -0.3, 0.0]))
    objects = moved(objects, 5, translation([0.0, -0.3, 0.0]))
    edges = tuple(Edge(e.child, e.relation, e.parent, 0.4) if e.child == 4 else e for e in graph.edges)
    cfg = AttachmentConfig(stop_after="relations")
    layout = attach(objects, SceneGraph(edges), shell, cfg)
    # the weak edge keeps the floor-only result (no move); the confident one is mounted
    assert layout.world_from_asset[InstanceId(4)][1, 3] == objects[InstanceId(4)].world_from_asset[1, 3]
    assert abs(layout.world_from_asset[InstanceId(5)][1, 3] - 4.985) < 1e-9
    choice = [op for op in layout.operations if op["stage"] == "dual attachment" and op["instance"] == 4]
    assert choice and choice[0]["rule"] == "keep floor-only" and "confidence" in choice[0]["reason"]


def test_single_branch_when_dual_is_off():
    objects, graph, shell = scene()
    on = attach(objects, graph, shell, AttachmentConfig(dual_attachment=True))
    off = attach(objects, graph, shell, AttachmentConfig(dual_attachment=False))
    # dual attachment solves a floor-only branch beside the wall-aware one; without it only one branch runs
    assert {op["branch"] for op in on.operations} >= {"wall-aware", "floor-only"}
    assert off.operations and {op["branch"] for op in off.operations} <= {"wall-aware", "all"}
    assert not [op for op in off.operations if op["stage"] == "dual attachment"]
    wall_aware_on = [op for op in on.operations if op["branch"] == "wall-aware"]
    assert [(op["stage"], op["rule"], op["instance"]) for op in off.operations] == [
        (op["stage"], op["rule"], op["instance"]) for op in wall_aware_on
    ]
    # every edge here is confident, so the dual solver keeps the wall-aware result: the same poses
    for iid, world_from_asset in on.world_from_asset.items():
        np.testing.assert_allclose(off.world_from_asset[iid], world_from_asset, atol=1e-12)
