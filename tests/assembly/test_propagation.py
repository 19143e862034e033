"""Propagation along the graph: children move with parents; omega scales the update on sim(3)."""

from __future__ import annotations

import numpy as np
import pytest

from rescene_core.assembly import attach
from rescene_core.assembly.transforms import translation
from rescene_core.config import AttachmentConfig
from rescene_core.records import Edge, InstanceId, SceneGraph
from tests.assembly.helpers import moved, scene

RELATIONS = AttachmentConfig(stop_after="relations", dual_attachment=False, floor_trust_min_confidence=None)
"""Eq. 5 on its own: weak floor edges are not trusted in full here (propagate.trusted_floor_edge)."""


def with_confidence(graph: SceneGraph, child: int, omega: float) -> SceneGraph:
    return SceneGraph(
        tuple(
            Edge(e.child, e.relation, e.parent, omega, e.scores, e.flags, e.wall_id) if e.child == child else e
            for e in graph.edges
        )
    )


def test_child_moves_with_parent():
    objects, graph, shell = scene()
    lift = translation([0.0, 0.0, 0.3])
    objects = moved(objects, 2, lift)  # nightstand floating ...
    objects = moved(objects, 3, lift)  # ... with its lamp
    layout = attach(objects, graph, shell, RELATIONS)
    lamp = objects[InstanceId(3)].world_vertices(layout.world_from_asset[InstanceId(3)])
    assert lamp[:, 2].min() == pytest.approx(0.55, abs=1e-9)


def test_omega_zero_means_no_change():
    objects, graph, shell = scene()
    objects = moved(objects, 3, translation([0.1, 0.0, 0.25]))
    graph = with_confidence(graph, 3, 0.0)
    layout = attach(objects, graph, shell, RELATIONS)
    np.testing.assert_allclose(
        layout.world_from_asset[InstanceId(3)], objects[InstanceId(3)].world_from_asset, atol=1e-12
    )


def test_omega_zero_child_still_follows_its_parent():
    objects, graph, shell = scene()
    objects = moved(objects, 2, translation([0.0, 0.0, 0.2]))
    graph = with_confidence(graph, 3, 0.0)
    layout = attach(objects, graph, shell, RELATIONS)
    start = objects[InstanceId(3)].world_from_asset[2, 3]
    assert layout.world_from_asset[InstanceId(3)][2, 3] == pytest.approx(start - 0.2)


def test_omega_half_is_half_the_translation():
    objects, graph, shell = scene()
    objects = moved(objects, 6, translation([0.0, 0.0, 0.4]))
    graph = with_confidence(graph, 6, 0.5)
    layout = attach(objects, graph, shell, RELATIONS)
    assert layout.world_from_asset[InstanceId(6)][2, 3] == pytest.approx(0.2)
    op = next(o for o in layout.operations if o["instance"] == 6 and o["stage"] == "floor snap")
    assert op["omega"] == 0.5


def test_ops_record_local_update_composing_to_delta():
    objects, graph, shell = scene()
    objects = moved(objects, 2, translation([0.0, 0.0, 0.2]))
    objects = moved(objects, 3, translation([0.05, 0.0, 0.35]))
    layout = attach(objects, graph, shell, RELATIONS)
    ops = {o["instance"]: o for o in layout.operations if o["stage"] in ("floor snap", "object support")}
    parent_delta = np.asarray(ops[2]["transform"])
    child_update = np.asarray(ops[3]["transform"])
    child_delta = layout.world_from_asset[InstanceId(3)] @ np.linalg.inv(objects[InstanceId(3)].world_from_asset)
    np.testing.assert_allclose(parent_delta @ child_update, child_delta, atol=1e-9)
