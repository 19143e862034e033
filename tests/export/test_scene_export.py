"""scene.glb with one named node per object plus the shell; scene.json; per-object meshes."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.records import Edge, InstanceId, Missing, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(
        WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),
        WallPlane(1, Plane((-1.0, 0.0, 0.0), 2.0), ((2.0, -2.0), (2.0, 2.0))),
    ),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
)


def test_export_scene(tmp_path):
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    pose = np.eye(4)
    pose[:3, :3] *= 0.8
    pose[:3, 3] = [0.5, -1.0, 0.4]
    objs = [
        ExportObject(3, "night stand", np.asarray(box.vertices), np.asarray(box.faces), pose, np.eye(4)),
        ExportObject(5, "lamp", np.asarray(box.vertices) * 0.2, np.asarray(box.faces), np.eye(4)),
    ]
    graph = SceneGraph(
        (Edge(InstanceId(3), Relation.RESTS_ON, Root.FLOOR), Edge(InstanceId(5), Relation.RESTS_ON, InstanceId(3)))
    )
    missing = [Missing(InstanceId(9), "registration", "gates rejected")]
    hashes = export_scene(tmp_path, objs, SHELL, graph, missing, ExportConfig(), extra={"scene_id": "t"})
    assert set(hashes) == {
        "scene.glb",
        "scene.json",
        "points.zarr",
        "objects/obj_3_night_stand.glb",
        "objects/obj_5_lamp.glb",
    }

    scene = trimesh.load(tmp_path / "scene.glb", force="scene")
    nodes = set(scene.graph.nodes_geometry)
    assert {"obj_3_night_stand", "obj_5_lamp", "shell_floor", "shell_wall_0", "shell_wall_1"} <= nodes
    transform, _ = scene.graph["obj_3_night_stand"]
    assert transform == pytest.approx(pose)
    floor = scene.geometry[scene.graph["shell_floor"][1]].copy().apply_transform(scene.graph["shell_floor"][0])
    wall = scene.geometry[scene.graph["shell_wall_0"][1]].copy().apply_transform(scene.graph["shell_wall_0"][0])
    assert floor.bounds[:, 2] == pytest.approx([-ExportConfig().floor_thickness, 0.0])
    assert wall.bounds[:, 2] == pytest.approx([0.0, ExportConfig().wall_height])
    assert wall.bounds[1, 1] == pytest.approx(-2.0)  # the slab lies behind the wall plane y = -2

    doc = json.loads((tmp_path / "scene.json").read_text())
    assert doc["format"] == "rescene-scene" and doc["units"] == "m" and doc["scene_id"] == "t"
    obj3 = doc["objects"][0]
    assert obj3["node"] == "obj_3_night_stand" and obj3["scale"] == pytest.approx(0.8)
    assert obj3["parent"] == "floor" and doc["objects"][1]["parent"] == 3
    assert doc["missing"] == [m.to_json() for m in missing]
    assert RoomShell.from_json(doc["shell"]) == SHELL
    mesh = trimesh.load(tmp_path / obj3["mesh"], force="mesh")
    assert len(mesh.faces) == len(box.faces)
