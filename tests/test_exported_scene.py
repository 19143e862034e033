"""scene/scene.json's one reader and writer (rescene_core/exported_scene.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rescene_core.exported_scene import ExportedObject, ExportedScene, SceneFileError
from rescene_core.records import Edge, InstanceId, Missing, Relation, Root, SceneGraph, Stage


def _scene() -> ExportedScene:
    m = np.eye(4)
    m[:3, 3] = (1.0, 2.0, 0.0)
    objects = (
        ExportedObject(InstanceId(2), "cabinet/wardrobe part", "obj_2_cabinet_wardrobe_part",
                       "objects/obj_2_cabinet_wardrobe_part.glb", m, 1.0, np.eye(4), "floor", "rests-on"),
        ExportedObject(InstanceId(5), "crème jar", "obj_5_creme_jar", "objects/obj_5_creme_jar.glb", 0.5 * m, 0.5),
    )  # fmt: skip
    graph = SceneGraph((Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 0.9),))
    missing = (Missing(InstanceId(7), Stage.REGISTRATION, "gates"),)
    return ExportedScene(objects, graph, None, (), missing, {"scene_id": "s", "capture": "/data/s.zarr"})


def test_written_file_reads_back_to_the_same_bytes(tmp_path):
    path = _scene().write(tmp_path / "scene.json")
    again = ExportedScene.read(path)
    assert again.write(tmp_path / "again.json").read_bytes() == path.read_bytes()
    assert again.object(2).label == "cabinet/wardrobe part" and again.object(5).parent is None
    assert again.capture == "/data/s.zarr" and again.extra["scene_id"] == "s"
    assert again.missing == _scene().missing and again.graph == _scene().graph
    np.testing.assert_array_equal(again.object(2).world_from_asset, _scene().object(2).world_from_asset)


def test_another_format_or_a_newer_version_is_refused_by_name(tmp_path):
    path = tmp_path / "scene.json"
    doc = _scene().to_json()
    path.write_text(json.dumps({**doc, "version": 99}))
    with pytest.raises(SceneFileError, match="scene.json: format 'rescene-scene' version 99"):
        ExportedScene.read(path)
    with pytest.raises(FileNotFoundError, match="rescene run"):
        ExportedScene.read(tmp_path / "none.json")
