"""Structural metrics detect floating, sunk, out-of-room, colliding and detached objects."""

from __future__ import annotations

import numpy as np

from rescene_core.assembly.transforms import rotation_about, translation
from rescene_core.evaluation.structural import structural_metrics
from tests.assembly.helpers import moved, scene


def test_clean_scene_passes_everything():
    objects, graph, shell = scene()
    m = structural_metrics(objects, None, graph, shell)
    assert m["object_count"] == 6
    assert (m["floor_contact_pass"], m["wall_contact_pass"], m["support_contact_pass"]) == (1.0, 1.0, 1.0)
    assert m["attachment_contact_pass"] == 1.0 and m["oob_rate"] == 0.0 and m["collision_rate"] == 0.0
    # 6 objects, 15 pairs, 1 related (lamp on nightstand)
    assert m["non_related_pairs"] == 14


def test_failures_are_counted():
    objects, graph, shell = scene()
    registered = {i: o.world_from_asset for i, o in objects.items()}
    objects = moved(objects, 1, translation([0.0, 0.0, 0.1]))  # bed floating
    objects = moved(objects, 6, translation([0.5, 0.0, 0.0]))  # wardrobe through the east wall
    objects = moved(objects, 4, rotation_about([0, 0, np.radians(20)], [1.6, 4.985, 1.45]))  # picture turned
    objects = moved(objects, 3, translation([0.0, 0.0, 0.1]))  # lamp floating
    objects = moved(objects, 2, translation([0.4, 0.0, 0.0]))  # nightstand into the bed
    m = structural_metrics(objects, None, graph, shell, registered=registered)
    assert m["contact_failures"]["floor"] == [1]
    assert m["oob_objects"] == [4, 6]  # the turned picture pokes through the wall too
    assert m["contact_failures"]["wall"] == [4]
    assert m["contact_failures"]["support"] == [3]
    assert [1, 2] in m["colliding"]
    assert m["pose_change"]["6"]["centre_m"] == 0.5


def test_contained_object_counts_as_collision():
    from rescene_core.assembly.scenes import box_object, placed
    from rescene_core.records import SceneGraph

    _, _, shell = scene()
    big = box_object(1, "box", (1.0, 1.0, 1.0), placed(2.0, 2.0))
    small = box_object(2, "box", (0.2, 0.2, 0.2), placed(2.0, 2.0, 0.3))
    m = structural_metrics({1: big, 2: small}, None, SceneGraph(()), shell)
    assert m["collision_pairs"] == 1
