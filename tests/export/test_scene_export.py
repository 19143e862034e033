"""scene.glb with one named node per object plus the shell; scene.json; per-object meshes."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.gltf import ROOT_NODE, split_glb
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
        "mjcf",
        "mjcf/scene.xml",
        "scene.usda",
        "export_report.json",
    }

    scene = trimesh.load(tmp_path / "scene.glb", force="scene")
    nodes = set(scene.graph.nodes_geometry)
    assert {"obj_3_night_stand", "obj_5_lamp", "shell_floor", "shell_wall_0", "shell_wall_1"} <= nodes
    # glTF is +Y up: the z-up world hangs under one root node; undoing it gives world transforms back
    yup_from_zup = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=float)
    assert scene.graph[ROOT_NODE][0] == pytest.approx(yup_from_zup)
    zup_from_yup = np.linalg.inv(yup_from_zup)
    transform, _ = scene.graph["obj_3_night_stand"]
    assert zup_from_yup @ transform == pytest.approx(pose)

    def world(name):
        node_transform, geom = scene.graph[name]
        return scene.geometry[geom].copy().apply_transform(zup_from_yup @ node_transform)

    floor, wall = world("shell_floor"), world("shell_wall_0")
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

    doc, _ = split_glb((tmp_path / "scene.glb").read_bytes())
    by_name = {n.get("name"): n for n in doc["nodes"]}
    assert by_name["obj_5_lamp"]["extras"] == {
        "instance": 5,
        "label": "lamp",
        "relation": "rests-on",
        "parent": 3,
        "parent_node": "obj_3_night_stand",
        "confidence": 1.0,
        "wall_id": None,
        "children": [],
    }
    assert by_name["obj_3_night_stand"]["extras"]["children"] == ["obj_5_lamp"]
    assert by_name["obj_3_night_stand"]["scale"] == pytest.approx([0.8] * 3)
    assert by_name["shell_wall_1"]["extras"] == {"shell": "wall", "wall_id": 1}
