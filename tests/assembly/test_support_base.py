"""Support bases: a lamp whose generated mesh is its shade without the stem, registered on the shade's points
above a nightstand, keeps its pose and gets a base from the nightstand's top up into the mesh when its points
reach down to the top; not when they do not."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.config import AttachmentConfig
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

TOP = 0.58
"""Height of the nightstand's top (m)."""
SHADE_BOTTOM = 0.77
"""Where the lamp's generated mesh (its shade only) ends, 19 cm above the top."""


def _scene(stem_seen: bool):
    rng = np.random.default_rng(0)
    stand = box_object(1, "nightstand", (0.5, 0.4, TOP), placed(1.0, 1.0), exact_shape=False)
    stand_pts = np.c_[rng.uniform(0.76, 1.24, 2000), rng.uniform(0.81, 1.19, 2000), rng.uniform(0.0, TOP, 2000)]
    stand = replace(stand, points=stand_pts)
    lamp = box_object(2, "table lamp", (0.26, 0.26, 0.25), placed(1.0, 1.0, SHADE_BOTTOM), exact_shape=False)
    shade = np.c_[rng.uniform(0.87, 1.13, 1500), rng.uniform(0.87, 1.13, 1500), rng.uniform(0.79, 1.02, 1500)]
    stem = np.c_[rng.normal(1.0, 0.01, 100), rng.normal(1.0, 0.01, 100), rng.uniform(TOP, SHADE_BOTTOM, 100)]
    lamp = replace(lamp, points=np.vstack([shade, stem]) if stem_seen else shade)
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.9),
        )
    )
    return {InstanceId(1): stand, InstanceId(2): lamp}, graph, rect_room()


def test_a_lamp_seen_down_to_its_support_gets_a_base_there():
    objects, graph, shell = _scene(stem_seen=True)
    layout = attach(objects, graph, shell, AttachmentConfig())
    pose = layout.world_from_asset[InstanceId(2)]
    np.testing.assert_allclose(pose[:3, 3], [1.0, 1.0, SHADE_BOTTOM], atol=0.01)  # kept where its shade was seen
    (base,) = [c for c in layout.completions()[InstanceId(2)] if c.kind.value == "base"]
    assert "reach down to its support" in base.source
    world = apply(pose, base.points_asset)
    assert world[:, 2].min() == np.float64(world[:, 2].min()) and abs(world[:, 2].min() - TOP) < 0.01
    assert SHADE_BOTTOM < world[:, 2].max() < SHADE_BOTTOM + 0.02  # 1 cm into the mesh
    # under the stem the points showed, not the whole shade
    span = world[:, :2].max(axis=0) - world[:, :2].min(axis=0)
    assert (span < 0.15).all()


def test_a_lamp_whose_points_stop_at_its_shade_gets_no_support_base():
    objects, graph, shell = _scene(stem_seen=False)
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert all(c.kind.value != "base" for c in layout.completions().get(InstanceId(2), []))
