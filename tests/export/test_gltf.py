"""glTF files pass the Khronos validator (npm gltf-validator, run with Node) with zero errors."""

from __future__ import annotations

import numpy as np
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.gltf import join_glb, split_glb, trs_from_matrix, validate_gltf
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
)


def test_scene_and_objects_validate(tmp_path):
    chair = trimesh.creation.cylinder(radius=0.3, height=0.8, sections=24)
    turned = sim3.sim3_from_parts(1.3, trimesh.transformations.rotation_matrix(0.7, [0, 0, 1])[:3, :3], [1, 0, 0.5])
    objs = [
        ExportObject(2, "chair", chair.vertices, chair.faces, turned),
        ExportObject(4, "table lamp", chair.vertices * 0.2, chair.faces, np.eye(4)),
    ]
    graph = SceneGraph((Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR),))
    export_scene(tmp_path, objs, SHELL, graph, [], ExportConfig())
    files = [tmp_path / "scene.glb", *sorted((tmp_path / "objects").glob("*.glb"))]
    assert len(files) == 3
    for path in files:
        report = validate_gltf(path)
        assert report.errors == 0, report.messages


def test_validator_reports_errors(tmp_path):
    """The check can fail: an accessor pointing past the end of its buffer is an error."""
    box = trimesh.creation.box()
    doc, binary = split_glb(box.export(file_type="glb"))
    doc["accessors"][0]["count"] *= 50
    bad = tmp_path / "bad.glb"
    bad.write_bytes(join_glb(doc, binary))
    report = validate_gltf(bad)
    assert report.errors > 0 and not report.ok


def test_trs_round_trip():
    pose = sim3.sim3_from_parts(0.7, trimesh.transformations.random_rotation_matrix()[:3, :3], [0.1, -2, 3])
    trs = trs_from_matrix(pose)
    rebuilt = trimesh.transformations.quaternion_matrix(np.roll(trs["rotation"], 1))
    rebuilt[:3, :3] *= trs["scale"][0]
    rebuilt[:3, 3] = trs["translation"]
    np.testing.assert_allclose(rebuilt, pose, atol=1e-12)
