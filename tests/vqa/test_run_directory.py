"""End to end on a run directory made from a tiny synthetic capture's ground truth (the files a run writes:
shell.json, scenegraph/graph.json, layout.json, instances/<id>/asset.{glb,json}, scene/scene.json)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from flows.cli import main
from rescene_core.assets import save_asset
from rescene_core.capture.synth import make_scene
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.io import write_json_atomic
from rescene_core.records import Asset, Edge, InstanceId, Layout, Root, SceneGraph
from rescene_core.vqa import VqaConfig, VqaInputError, build_vqa, read_questions, read_run, scene_from_ground_truth

LOW = 0.5  # confidence given to the first object-on-object edge, below the default threshold


@pytest.fixture(scope="module")
def tiny_gt():
    return make_scene("tiny", 0).gt


def _graph_with_one_uncertain_edge(gt) -> tuple[SceneGraph, Edge]:
    edges = list(gt.graph_by_instance().edges)
    k = next(i for i, e in enumerate(edges) if not isinstance(e.parent, Root))
    e = edges[k]
    edges[k] = Edge(e.child, e.relation, e.parent, LOW, e.scores, e.flags, e.wall_id)
    return SceneGraph(tuple(edges)), edges[k]


def write_run_from_gt(gt, run: Path) -> Edge:
    """A run directory with the ground-truth meshes as assets and the ground-truth poses as the layout."""
    graph, uncertain = _graph_with_one_uncertain_edge(gt)
    primary = gt.primary_instance()
    placed, exports = {}, []
    for obj in gt.objects:
        if obj.object_id not in primary:
            continue
        inst = primary[obj.object_id]
        save_asset(run / "instances" / str(inst) / "asset.glb", Asset(InstanceId(inst), obj.vertices, obj.faces, "gt"))
        write_json_atomic(run / "instances" / str(inst) / "asset.json", {"instance": inst, "glb": "asset.glb"})
        placed[InstanceId(inst)] = obj.world_from_object
        exports.append(ExportObject(inst, obj.label, obj.vertices, obj.faces, obj.world_from_object))
    write_json_atomic(run / "shell.json", gt.shell.to_json())
    write_json_atomic(run / "scenegraph" / "graph.json", graph.to_json())
    write_json_atomic(run / "layout.json", Layout(placed).to_json())
    export_scene(run / "scene", exports, gt.shell, graph, [], ExportConfig(), extra={"scene_id": "tiny-0"})
    return uncertain


@pytest.fixture
def run_dir(tiny_gt, tmp_path) -> tuple[Path, Edge]:
    run = tmp_path / "run"
    return run, write_run_from_gt(tiny_gt, run)


def test_read_run_matches_ground_truth(tiny_gt, run_dir):
    run, _ = run_dir
    scene = read_run(run)
    truth = scene_from_ground_truth(tiny_gt)
    assert scene.ids == truth.ids and scene.scene_id == "tiny-0"
    for o in truth.objects:
        got = scene.object(o.id)
        assert got.label == o.label
        assert np.allclose(got.box_min, o.box_min, atol=1e-5) and np.allclose(got.box_max, o.box_max, atol=1e-5)


def test_cli_writes_questions_views_and_summary(tiny_gt, run_dir, capsys):
    run, uncertain = run_dir
    assert main(["vqa", str(run), "--views", "2", "--seed", "1"]) == 0
    assert "questions" in capsys.readouterr().out
    out = run / "vqa"
    summary = json.loads((out / "summary.json").read_text())
    items = read_questions(out / "questions.jsonl")
    assert summary["questions"] == len(items) > 0
    assert len(summary["views"]) == 2 and len(list((out / "views").glob("*.png"))) == 2
    assert summary["config"]["views"] == 2 and summary["config"]["seed"] == 1
    assert summary["filtered"]["support_relation"].get("low_confidence", 0) >= 1

    truth = scene_from_ground_truth(tiny_gt)
    ids = set(truth.ids)
    parents = truth.edges()
    for item in items:
        assert set(item.object_ids) <= ids
        if item.template == "rests_on":
            child = item.object_ids[0]
            assert child != int(uncertain.child)
            e = parents[child]
            assert item.answer == ("floor" if e.parent == Root.FLOOR else truth.object(int(e.parent)).label)
        if item.template == "which_wall":
            assert item.answer == "east wall"  # the tiny room's picture hangs on wall 1, normal -x
    assert not any(item.template == "rests_on" and item.object_ids[0] == int(uncertain.child) for item in items)


def test_out_dir_and_determinism(run_dir, tmp_path):
    run, _ = run_dir
    assert main(["vqa", str(run), "--views", "1", "--out", str(tmp_path / "a")]) == 0
    assert main(["vqa", str(run), "--views", "1", "--out", str(tmp_path / "b")]) == 0
    a, b = ((tmp_path / d / "questions.jsonl").read_text() for d in "ab")
    assert a == b and not (run / "vqa").exists()


def test_missing_graph_skips_and_counts_relation_questions(run_dir, tmp_path):
    run, _ = run_dir
    (run / "scenegraph" / "graph.json").unlink()
    scene = read_run(run)
    assert scene.missing_graph is not None and "graph.json" in scene.missing_graph
    assert main(["vqa", str(run), "--views", "1", "--out", str(tmp_path / "v")]) == 0
    summary = json.loads((tmp_path / "v" / "summary.json").read_text())
    assert summary["skipped"]["graph"] is not None
    for cat in ("support_relation", "attachment_relation", "multi_hop"):
        assert summary["counts"][cat] == 0 and summary["filtered"][cat]["missing_graph"] == 1
    assert summary["counts"]["object_recognition"] > 0


def test_missing_asset_skipped_and_counted_then_empty_layout(run_dir):
    run, _ = run_dir
    layout = json.loads((run / "layout.json").read_text())
    first = sorted(layout["objects"], key=int)[0]
    shutil.rmtree(run / "instances" / first)
    scene = read_run(run)
    assert [i for i, _ in scene.missing_instances] == [int(first)]
    assert int(first) not in scene.ids
    generated = build_vqa(scene, VqaConfig(views=0))
    assert all(int(first) not in item.object_ids for item in generated.items)
    write_json_atomic(run / "layout.json", {"objects": {}, "operations": [], "missing": []})
    with pytest.raises(VqaInputError, match="no placed objects"):
        read_run(run)


def test_ground_truth_scene_gives_every_category(tiny_gt):
    dataset = build_vqa(scene_from_ground_truth(tiny_gt), VqaConfig(views=2, image_width=96, image_height=72))
    counts = dataset.summary["counts"]
    assert all(counts[c] > 0 for c in ("object_recognition", "relative_position", "support_relation"))
    assert counts["attachment_relation"] > 0 and counts["multi_hop"] > 0


@pytest.mark.slow  # a tiny capture is written, then four scenes are walked and rendered
def test_faithfulness_of_a_run_against_its_capture(tmp_path, capsys):
    """A run that is its capture's ground truth agrees on every question; a wrong label makes it disagree."""
    from rescene_core.capture import open_capture
    from rescene_core.capture.ground_truth import read_ground_truth
    from rescene_core.capture.synth import write_synth

    capture = write_synth(tmp_path / "room.zarr", "tiny", seed=0)
    run = tmp_path / "run"
    write_run_from_gt(read_ground_truth(open_capture(capture)), run)
    args = ["vqa", "faithfulness", str(run), str(capture), "--steps", "8", "--per-category", "10"]
    args += ["--json", str(tmp_path / "f.json")]
    assert main(args) == 0
    result = json.loads((tmp_path / "f.json").read_text())
    assert result["questions"] > 10 and result["agreement"] == 1.0 and result["gt_self"] == 1.0
    assert "agreement 1.000" in capsys.readouterr().out
    scene_json = run / "scene" / "scene.json"
    doc = json.loads(scene_json.read_text())
    counts = {}
    for o in doc["objects"]:
        counts[o["label"]] = counts.get(o["label"], 0) + 1
    victim = next(o for o in doc["objects"] if counts[o["label"]] == 1)
    victim["label"] = "aquarium"
    scene_json.write_text(json.dumps(doc))
    assert main(args) == 0
    result = json.loads((tmp_path / "f.json").read_text())
    assert result["disagree"] + result["unanswerable"] > 0 and result["agreement"] < 1.0
