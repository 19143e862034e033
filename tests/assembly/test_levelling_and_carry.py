"""Levelling about what the capture saw, and what a child inherits of its support's correction."""

from dataclasses import replace

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.assembly.transforms import rotation_about
from rescene_core.config import AttachmentConfig
from rescene_core.geometry.sim3 import apply, inverse
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph


def test_a_tilted_generated_mesh_is_levelled_about_its_observed_points():
    # a 0.6 m tall cabinet seen only from above (points on its top), registered tilted 8 deg about x
    rng = np.random.default_rng(0)
    upright = placed(2.0, 2.5)
    top = np.c_[rng.uniform(-0.3, 0.3, 400), rng.uniform(-0.2, 0.2, 400), np.full(400, 0.6)]
    tilt = rotation_about([np.radians(8.0), 0.0, 0.0], [2.0, 2.5, 0.3])
    pose = tilt @ upright
    cabinet = box_object(1, "cabinet", (0.6, 0.4, 0.6), pose, exact_shape=False)
    cabinet = replace(cabinet, points=apply(pose, top))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    layout = attach({InstanceId(1): cabinet}, graph, rect_room(), AttachmentConfig(stop_after="relations"))
    final = layout.world_from_asset[InstanceId(1)]
    seen = np.median(cabinet.points, axis=0)
    carried = apply(final @ inverse(pose), seen[None])[0]
    # the seen top stays where it was seen; about the box centre it slid 0.3 m x sin(8 deg) = 4 cm
    assert np.linalg.norm(carried[:2] - seen[:2]) < 0.005
    level_axis = final[:3, 2] / np.linalg.norm(final[:3, 2])
    assert level_axis[2] > np.cos(np.radians(0.5))  # levelled
