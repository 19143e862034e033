"""Scene-level tasks through ``task.fn()``: capture validation, shell, key frames, relations, fusion,
the registration snapshot, attachment, export and evaluation."""

from __future__ import annotations

import dataclasses
import json

import pytest

from rescene_core.capture import CaptureError
from rescene_core.config import (
    AssetConfig,
    AttachmentConfig,
    HierViewConfig,
    KeyFrameConfig,
    RegistrationConfig,
    SceneGraphConfig,
    ShellConfig,
)
from rescene_core.export import ExportConfig
from rescene_core.io import hash_file
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Missing, Stage
from rescene_core.stages import calls as stages
from rescene_core.stages.execution import TransientStageError
from rescene_core.stages.keyframes import keyframes_of
from tasks import dag as T
from tasks.dag import generate_asset, register_instance, select_views

WALLS = (ExportConfig().wall_height, ExportConfig().wall_thickness)
"""How the run log draws the walls (height, thickness in m)."""


@pytest.fixture
def placed(fake_stages, capture, tmp_path):
    """Views, assets and poses of the three boxes, and the room shell."""
    rd = str(tmp_path)
    views = select_views.fn(rd, capture, [2, 3, 4], HierViewConfig())
    assets = [generate_asset.fn(rd, capture, v, AssetConfig()) for v in views]
    poses = [register_instance.fn(rd, capture, a, RegistrationConfig()) for a in assets]
    shell = T.estimate_shell.fn(rd, capture, ShellConfig())
    return shell, assets, poses


def test_validate_counts_frames_and_instances(capture):
    ref = T.validate_capture.fn(capture)
    assert ref.numbers == {"frames": 3, "instances": 4} and ref.sha256 == capture.sha256


def test_validate_rejects_a_bad_capture(tmp_path):
    import zarr

    from rescene_core.stages.execution import capture_ref
    from tests.flows.fakes import box_capture

    path = box_capture(tmp_path / "bad.zarr")
    zarr.open_group(str(path), mode="r+").attrs["format"] = "other"
    with pytest.raises(CaptureError, match="format"):
        T.validate_capture.fn(capture_ref(path))


def test_shell_and_keyframes(fake_stages, capture, tmp_path):
    shell = T.estimate_shell.fn(str(tmp_path), capture, ShellConfig())
    run = RunPaths(tmp_path)
    assert shell.path == "shell.json" and shell.sha256 == hash_file(run.shell)
    assert shell.numbers["walls"] == 1 and shell.numbers["floor_area"] == pytest.approx(16.0)
    keyframes = T.select_keyframes.fn(str(tmp_path), capture, KeyFrameConfig())
    assert keyframes_of(str(tmp_path), keyframes) == [0, 2] and keyframes.numbers == {"count": 2}
    assert json.loads(run.keyframes.read_text())["frames"] == [0, 2]


def test_relations_write_the_frame_and_retry_a_failed_endpoint(fake_stages, capture, tmp_path, monkeypatch):
    shell = T.estimate_shell.fn(str(tmp_path), capture, ShellConfig())
    ref = T.predict_relations.fn(str(tmp_path), capture, shell, 2, SceneGraphConfig())
    assert ref.item == 2 and ref.path == "scenegraph/frames/2.json"
    assert json.loads(RunPaths(tmp_path).frame_json(2).read_text())["visible"] == [2, 3, 4]

    @dataclasses.dataclass
    class Attempt:
        transport_error: str

    @dataclasses.dataclass
    class Failed:
        status: str = "failed"
        attempts: tuple = (Attempt("read timed out"),)

    monkeypatch.setattr(stages, "predict_frame", lambda *args: Failed())
    with pytest.raises(TransientStageError, match="read timed out"):
        T.predict_relations.fn(str(tmp_path), capture, shell, 0, SceneGraphConfig())


def test_fusion_leaves_out_the_missing_instances(fake_stages, capture, tmp_path):
    rd = str(tmp_path)
    shell = T.estimate_shell.fn(rd, capture, ShellConfig())
    preds = [T.predict_relations.fn(rd, capture, shell, t, SceneGraphConfig()) for t in (0, 2)]
    missing = [Missing(InstanceId(3), Stage.REGISTRATION, "gates")]
    graph = T.fuse_graph.fn(rd, capture, shell, preds, missing, SceneGraphConfig())
    edges = json.loads(RunPaths(tmp_path).graph.read_text())["edges"]
    assert [e["child"] for e in edges] == [2, 4] and graph.numbers == {"edges": 2, "uncertain": 0}


def test_snapshot_attachment_export_evaluation(placed, capture, tmp_path):
    rd = str(tmp_path)
    shell, assets, poses = placed
    snap = T.snapshot_registration.fn(rd, capture, shell, assets, poses, *WALLS)
    assert snap.numbers == {"objects": 3} and snap.path == "logs/after_registration.json"
    preds = [T.predict_relations.fn(rd, capture, shell, t, SceneGraphConfig()) for t in (0, 2)]
    graph = T.fuse_graph.fn(rd, capture, shell, preds, [], SceneGraphConfig())
    layout = T.attach_layout.fn(rd, capture, shell, graph, assets, poses, AttachmentConfig(), *WALLS)
    assert layout.path == "layout.json" and layout.numbers == {"objects": 3, "operations": 3, "missing": 0}
    missing = [Missing(InstanceId(9), Stage.ASSET, "no mesh")]
    scene = T.export.fn(rd, capture, shell, graph, layout, assets, poses, missing, ExportConfig())
    run = RunPaths(tmp_path)
    doc = json.loads(run.scene_json.read_text())
    assert [o["instance"] for o in doc["objects"]] == [2, 3, 4] and doc["missing"][0]["instance"] == 9
    assert scene.numbers == {"objects": 3} and scene.detail["files"]["scene.json"] == hash_file(run.scene_json)
    metrics = T.evaluate.fn(rd, capture, scene)
    assert metrics.path == "eval/metrics.json" and run.report_md.exists()
    assert json.loads(run.metrics.read_text())["objects"] == 3


def test_export_hashes_every_file_and_starts_the_evaluation_metrics(placed, capture, tmp_path):
    """The export writes the visual scene, starts the evaluation's scene metrics, then adds the simulation
    exports; its reference covers every file as export_scene's own hashes do, and the evaluation takes
    what was started."""
    from rescene_core.evaluation import run as evaluation
    from rescene_core.io import hash_tree

    rd = str(tmp_path)
    shell, assets, poses = placed
    preds = [T.predict_relations.fn(rd, capture, shell, t, SceneGraphConfig()) for t in (0, 2)]
    graph = T.fuse_graph.fn(rd, capture, shell, preds, [], SceneGraphConfig())
    layout = T.attach_layout.fn(rd, capture, shell, graph, assets, poses, AttachmentConfig(), *WALLS)
    evaluation._STARTED.clear()
    scene = T.export.fn(rd, capture, shell, graph, layout, assets, poses, [], ExportConfig())
    run = RunPaths(tmp_path)
    files = scene.detail["files"]
    assert {"scene.json", "scene.glb", "points.zarr", "mjcf", "mjcf/scene.xml", "export_report.json"} <= set(files)
    for rel, sha in files.items():
        assert sha == (hash_tree(run.scene / rel) if (run.scene / rel).is_dir() else hash_file(run.scene / rel)), rel
    assert len(evaluation._STARTED) == 1
    T.evaluate.fn(rd, capture, scene)
    assert not evaluation._STARTED


def test_attachment_of_no_objects_does_not_call_the_library(fake_stages, capture, tmp_path):
    rd = str(tmp_path)
    shell = T.estimate_shell.fn(rd, capture, ShellConfig())
    graph = T.fuse_graph.fn(rd, capture, shell, [], [], SceneGraphConfig())
    layout = T.attach_layout.fn(rd, capture, shell, graph, [], [], AttachmentConfig(), *WALLS)
    assert layout.numbers == {"objects": 0, "operations": 0, "missing": 0} and fake_stages["attachment"] == 0
