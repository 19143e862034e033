"""The geometry and rendering metrics started before the evaluation (while the export decomposes colliders) are
taken by the evaluation when it reads the same files, and are the metrics it would have computed."""

from __future__ import annotations

import pytest

from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation import run as evaluation
from rescene_core.evaluation.geometry import GeometryConfig
from rescene_core.evaluation.rendering import RenderingConfig
from rescene_core.evaluation.run import EvaluationConfig, start_scene_metrics
from tests.evaluation.scene import write_test_capture, write_test_run

SMALL = EvaluationConfig(html=False, rendering=RenderingConfig(scale=0.5), geometry=GeometryConfig(fuse_scale=0.5))


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    return write_test_capture(tmp_path_factory.mktemp("cap") / "room.zarr")


def _scene_sections(metrics):
    return {k: metrics[k] for k in ("geometry", "rendering")}


def test_started_metrics_are_taken_and_are_the_same(capture, tmp_path):
    run = write_test_run(tmp_path / "run", capture)
    plain = evaluate_run(run, capture, SMALL)
    start_scene_metrics(run, capture, SMALL)
    assert len(evaluation._STARTED) == 1
    early = evaluate_run(run, capture, SMALL)
    assert not evaluation._STARTED  # taken, once
    assert _scene_sections(early) == _scene_sections(plain)
    assert early["summary"] == plain["summary"]


def test_metrics_started_on_other_files_are_not_taken(capture, tmp_path):
    run = write_test_run(tmp_path / "run", capture)
    start_scene_metrics(run, capture, SMALL)
    write_test_run(run, capture, shift=0.2)  # the scene written again after the start (another export)
    again = evaluate_run(run, capture, SMALL)
    assert len(evaluation._STARTED) == 1  # left: it was for the scene before
    evaluation._STARTED.clear()
    fresh = evaluate_run(write_test_run(tmp_path / "shifted", capture, shift=0.2), capture, SMALL)
    assert _scene_sections(again)["geometry"]["ground_truth"] == _scene_sections(fresh)["geometry"]["ground_truth"]


def test_a_start_without_a_scene_does_nothing(capture, tmp_path):
    start_scene_metrics(tmp_path / "empty", capture, SMALL)
    assert not evaluation._STARTED
