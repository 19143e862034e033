"""`rescene vqa build`: many scenes, split by scene, records + SFT conversations + data card, read back with
the `datasets` library's json loader."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flows.cli import main
from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.vqa import scene_from_ground_truth, scene_from_synth_layout
from rescene_core.vqa.build import RECORD_FIELDS, scene_source, split_scenes


def _rows(path):
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_split_is_by_scene_reproducible_and_keeps_both_sides():
    ids = [f"s{i}" for i in range(13)]
    a = split_scenes(ids, 3 / 13, seed=0)
    assert a == split_scenes(list(reversed(ids)), 3 / 13, seed=0)
    assert sum(v == "test" for v in a.values()) == 3
    assert a != split_scenes(ids, 3 / 13, seed=1)
    assert sorted(split_scenes(["a", "b"], 0.01, 0).values()) == ["test", "train"]


def test_dataset_files_split_and_card(small_ds):
    out, card, calls = small_ds
    train, test = _rows(out / "train.jsonl"), _rows(out / "test.jsonl")
    assert len(train) == card["questions"]["train"] > 0 and len(test) == card["questions"]["test"] > 0
    assert {r["scene"] for r in train}.isdisjoint({r["scene"] for r in test})
    assert len([s for s in card["scenes"] if s["split"] == "test"]) == 1
    for r in train + test:
        assert list(r) == list(RECORD_FIELDS)
        assert r["choices"][ord(r["answer_letter"]) - ord("A")] == r["answer"]
        assert r["image"] is None or (out / r["image"]).is_file()
    assert any(r["image"] for r in test) and any(r["image"] is None for r in test)
    # the bad source is recorded, the others went on; one progress call per source
    assert len(card["failed"]) == 1 and "no-such-run" in card["failed"][0]["source"]
    assert [c[:2] for c in calls] == [(k, 5) for k in range(1, 6)]
    assert sum(card["per_task"]["train"].values()) == len(train)
    assert all(s["scene_backend"] == "synth-layout" and s["render_backend"] for s in card["scenes"])
    assert card["config"]["sampling"] == "walk"
    assert "| test |" in (out / "README.md").read_text()


def test_sft_conversations_match_records(small_ds):
    out, _, _ = small_ds
    records = {r["id"]: r for r in _rows(out / "test.jsonl")}
    for conv in _rows(out / "sft" / "test.jsonl"):
        r = records[conv["id"]]
        user, assistant = conv["messages"]
        assert user["role"] == "user" and assistant["role"] == "assistant"
        assert assistant["content"] == f"{r['answer_letter']}. {r['answer']}"
        assert user["content"].count("<image>") == len(conv["images"]) == (r["image"] is not None)


@pytest.mark.slow  # importing `datasets` takes about 10 s here
def test_datasets_json_loader_reads_records_and_conversations(small_ds):
    import datasets

    out, card, _ = small_ds
    d = datasets.load_dataset(
        "json", data_files={s: str(out / f"{s}.jsonl") for s in ("train", "test")}, cache_dir=str(out / ".hf")
    )
    assert d["train"].num_rows == card["questions"]["train"] and d["test"].num_rows == card["questions"]["test"]
    assert set(RECORD_FIELDS) <= set(d["test"].column_names)
    sft = datasets.load_dataset("json", data_files=str(out / "sft" / "train.jsonl"), cache_dir=str(out / ".hf"))
    assert sft["train"][0]["messages"][1]["role"] == "assistant"


def test_sources_and_cli(tmp_path, capsys):
    assert scene_source("synth:standard:3").kind == "synth"
    assert scene_source("a/room.zarr").kind == "capture"
    assert scene_source("runs/r0").kind == "run"
    assert main(["vqa", "build", "--out", str(tmp_path / "ds")]) == 2
    args = ["vqa", "build", "--synth", "tiny", "--seeds", "0-1", "--out", str(tmp_path / "ds"), "--steps", "2"]
    assert main(args + ["--per-category", "3"]) == 0
    assert "questions from 2 scenes" in capsys.readouterr().out
    assert (tmp_path / "ds" / "card.json").is_file()


def test_build_starts_from_the_run_config_and_applies_flags_over_it(tmp_path, capsys):
    config = tmp_path / "config.yaml"
    config.write_text("vqa:\n  per_category: 7\n  min_confidence: 0.9\n  walk_steps: 9\n")
    args = ["vqa", "build", "--synth", "tiny", "--seeds", "0", "--out", str(tmp_path / "ds")]
    args += ["--config", str(config), "--set", "vqa.walk_steps=2", "--per-category", "4"]
    assert main(args) == 0
    used = json.loads((tmp_path / "ds" / "card.json").read_text())["config"]
    assert used["per_category"] == 4  # the flag over the file
    assert used["min_confidence"] == 0.9  # the file: no flag for it
    assert used["walk_steps"] == 2  # --set over the file
    assert used["sampling"] == "walk" and used["walks"] == 1  # the data-set defaults where neither names them
    assert main(["vqa", "build", "--synth", "tiny", "--out", str(tmp_path / "x"), "--set", "vqa.nope=1"]) == 2
    assert "no setting 'nope'" in capsys.readouterr().err


def test_capture_source_uses_its_ground_truth(tmp_path):
    from rescene_core.capture.synth import write_synth
    from rescene_core.vqa import VqaConfig
    from rescene_core.vqa.build import build_dataset

    capture = write_synth(tmp_path / "room.zarr", "tiny", seed=2)
    (tmp_path / "broken.zarr").mkdir()
    sources = [scene_source(capture), scene_source(tmp_path / "broken.zarr")]
    card = build_dataset(sources, tmp_path / "ds", VqaConfig(views=0, per_category=5), test_ratio=0.0)
    assert [s["scene_backend"] for s in card["scenes"]] == ["ground-truth"]
    assert card["scenes"][0]["name"] == "synth-tiny-2" and card["scenes"][0]["split"] == "train"
    assert len(card["failed"]) == 1 and "broken.zarr" in card["failed"][0]["source"]
    assert card["questions"]["train"] > 0 and card["questions"]["test"] == 0
    # the synthetic layout without frames is the same scene as the capture's ground truth
    gt = read_ground_truth(open_capture(capture))
    from_capture, from_layout = scene_from_ground_truth(gt), scene_from_synth_layout("tiny", 2)
    primary = gt.primary_instance()
    assert len(from_layout.objects) == len(gt.objects)
    for o in from_layout.objects:
        if o.id in primary:
            twin = from_capture.object(primary[o.id])
            assert twin.label == o.label
            np.testing.assert_allclose(twin.box_min, o.box_min, atol=1e-9)
