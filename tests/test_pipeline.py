"""The in-process pipeline (rescene_core/pipeline.py) and the pipeline benchmark suite around it, with the
stage doubles of tests/flows/fakes.py on the hand-made box capture."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from rescene_core import pipeline
from rescene_core.bench import pipeline as suite
from rescene_core.records import InstanceId, Missing, Stage
from rescene_core.runlog import Segment, merge_segments
from rescene_core.stages import calls
from rescene_core.stages.dag import DAG
from tests.flows import fakes


@pytest.fixture
def fake_library(fake_stages):
    """The stage doubles of tests/flows/fakes.py in ``rescene_core.stages.calls`` (the ``fake_stages`` fixture)."""
    return fake_stages


@pytest.fixture(scope="module")
def boxes(tmp_path_factory):
    return fakes.box_capture(tmp_path_factory.mktemp("capture") / "boxes.zarr")


def test_every_stage_runs_once_in_order_and_the_scene_is_exported(fake_library, boxes, tmp_path):
    result = pipeline.run_pipeline(boxes, out_dir=tmp_path)
    assert dict(fake_library) == {"shell": 1, "view": 1, "asset": 3, "registration": 3, "keyframes": 1,
                                  "relations": 2, "fusion": 1, "attachment": 1}  # fmt: skip
    assert sorted(result.poses) == [2, 3, 4] and result.missing == ()
    assert set(result.seconds) == {s.stage for s in DAG}  # the physics check and the evaluation included
    scene = json.loads((tmp_path / "scene" / "scene.json").read_text())
    assert [o["instance"] for o in scene["objects"]] == [2, 3, 4]
    assert (tmp_path / "sim" / "simcheck.json").exists() and result.metrics is not None
    assert (tmp_path / "logs" / "run.mcap").exists()


def test_a_missing_instance_is_left_out_and_reported(fake_library, boxes, monkeypatch, tmp_path):
    monkeypatch.setattr(calls, "register", lambda asset, target, config: (
        Missing(asset.instance, "registration", "gates") if asset.instance == 3 else fakes.register(
            asset, target, config)))  # fmt: skip
    result = pipeline.run_pipeline(boxes, out_dir=tmp_path)
    assert sorted(result.poses) == [2, 4]
    assert result.missing == (Missing(InstanceId(3), Stage.REGISTRATION, "gates"),)
    assert [e.child for e in result.graph.edges] == [2, 4]  # fusion was told


def test_an_instance_that_raises_is_left_out_and_the_others_are_placed(fake_library, boxes, monkeypatch, tmp_path):
    def register(asset, target, config):
        if asset.instance == 4:
            raise RuntimeError("registration diverged")
        return fakes.register(asset, target, config)

    monkeypatch.setattr(calls, "register", register)
    result = pipeline.run_pipeline(boxes, out_dir=tmp_path)
    assert sorted(result.poses) == [2, 3]
    (miss,) = result.missing
    assert (miss.instance, miss.stage) == (4, Stage.REGISTRATION) and "registration diverged" in miss.reason
    scene = json.loads((tmp_path / "scene" / "scene.json").read_text())
    assert [o["instance"] for o in scene["objects"]] == [2, 3]


class FakeHarness:
    """Writes a run log as the flow would, so the suite can read per-stage task times from it."""

    def __init__(self) -> None:
        self.started = False
        self.runs: list[Path] = []
        self.caches: list[str | None] = []

    def start(self) -> None:
        self.started = True

    def run(self, capture: Path, run_dir: Path):
        self.runs.append(run_dir)
        self.caches.append(os.environ.get("RESCENE_CACHE_DIR"))
        time.sleep(0.05)  # a flow run takes time: the ratios to the library run stay above their rounding
        seg = Segment(run_dir, "registration-000002")
        seg.log("/task/events", {"stage": "registration", "item": 2, "event": "start", "seconds": 0.0})
        seg.log("/task/events", {"stage": "registration", "item": 2, "event": "end", "seconds": 0.25})
        seg.close()
        merge_segments(run_dir)

        class State:
            name, message = "Completed", None

        return State()


def test_the_suite_times_the_flow_three_times_and_the_library_once(fake_library, boxes, monkeypatch, tmp_path):
    monkeypatch.setattr(suite, "_capture", lambda work_dir, preset, seed: boxes)
    library_caches: list[str | None] = []
    real_pipeline = suite.run_pipeline

    def library(capture):
        library_caches.append(os.environ.get("RESCENE_CACHE_DIR"))
        return real_pipeline(capture)

    monkeypatch.setattr(suite, "run_pipeline", library)
    before = os.environ.get("RESCENE_CACHE_DIR")
    harness = FakeHarness()
    result = suite.run([0], "tiny", tmp_path, harness=harness)
    (row,) = result["runs"]
    assert harness.started and harness.runs == [tmp_path / "run_tiny_seed0"] * 2 + [tmp_path / "run_tiny_seed0_fresh"]
    # cold, cached and fresh-directory flow runs share one user cache; the library run has an empty one
    assert harness.caches == [str(tmp_path / "cache_flow_seed0")] * 3
    assert library_caches == [str(tmp_path / "cache_library_seed0")]
    assert os.environ.get("RESCENE_CACHE_DIR") == before
    assert row["state_cold"] == row["state_cached"] == row["state_fresh_dir"] == "Completed"
    assert row["seconds_fresh_dir"] > 0 and row["stage_seconds_fresh_dir"] == {"registration": 0.25}
    assert row["stage_seconds_flow"] == {"registration": 0.25}
    assert set(row["stage_seconds_library"]) >= {"shell", "registration", "export"}
    assert row["seconds_library"] > 0 and row["overhead_ratio"] > 0 and row["cached_fraction"] > 0
    assert result["summary"]["seconds_cold"] == row["seconds_cold"] and set(result["aims_met"]) == {
        "overhead_ratio", "seconds_cached", "seconds_cold"}  # fmt: skip
    text = suite.table({**result, "preset": "tiny", "seeds": [0]})
    assert "registration" in text and "aims:" in text
