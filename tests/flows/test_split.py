"""The split flow: the split file format, skip-if-done on capture content + config + code, a missing
capture failing only its scene, the summary table, and idempotent reruns (scenes run in process)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from flows.split import SplitFileError, done_reason, read_split, read_split_entries, scene_done
from rescene_core.config import RunConfig
from rescene_core.stages.execution import capture_ref

REPO = Path(__file__).resolve().parents[2]


def test_split_file_format(tmp_path):
    split = tmp_path / "split.txt"
    split.write_text("# nightly\n\na.zarr\n/abs/b.zarr  bee   # a comment\n")
    entries = read_split_entries(split)
    assert [(e.capture, e.name) for e in entries] == [
        ((tmp_path / "a.zarr").resolve(), "a"),
        (Path("/abs/b.zarr"), "bee"),
    ]
    assert read_split(split) == [(tmp_path / "a.zarr").resolve(), Path("/abs/b.zarr")]
    split.write_text("a.zarr\nother/a.zarr\n")
    with pytest.raises(SplitFileError, match="line 1; give one a NAME"):
        read_split_entries(split)
    split.write_text("a.zarr x y\n")
    with pytest.raises(SplitFileError, match=r"split.txt:1: 3 fields"):
        read_split_entries(split)
    with pytest.raises(SplitFileError, match="does not exist"):
        read_split_entries(tmp_path / "none.txt")


def test_example_split_reads():
    entries = read_split_entries(REPO / "deployments" / "splits" / "nightly.txt")
    assert entries and all(e.capture.is_absolute() for e in entries)


def test_done_reason(box_capture_path, tmp_path):
    from rescene_core.stages.dag import code_versions

    run = tmp_path / "run"
    sha = capture_ref(box_capture_path).sha256
    config = RunConfig()
    assert done_reason(run, sha, config) == "no manifest"
    run.mkdir()
    manifest = {
        "state": "Completed",
        "capture": {"sha256": sha},
        "config_hashes": {s: config.section_hash(s) for s in RunConfig.model_fields},
        "code_version": {"stages": {str(s): v for s, v in code_versions().items()}},
    }
    (run / "manifest.json").write_text(json.dumps(manifest))
    assert done_reason(run, sha, config) is None and scene_done(run, box_capture_path)
    assert done_reason(run, "0" * 64, config) == "capture content changed"
    assert done_reason(run, sha, config.with_overrides(["registration.scale_max=1.2"])) == "config changed"
    (run / "manifest.json").write_text(json.dumps({**manifest, "code_version": {"stages": {}}}))
    assert done_reason(run, sha, config) == "code changed"
    (run / "manifest.json").write_text(json.dumps({**manifest, "state": "Failed"}))
    assert done_reason(run, sha, config) == "last run Failed"
    (run / "manifest.json").write_text(json.dumps(manifest)[:40])  # cut short by a crash mid-write
    assert done_reason(run, sha, config) == "manifest unreadable (JSONDecodeError)"
    (run / "manifest.json").write_text("[]")
    assert done_reason(run, sha, config) == "manifest unreadable (not a JSON object)"


def test_split_runs_skips_and_reports(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.split import rescene_split

    other = shutil.copytree(box_capture_path, tmp_path / "other.zarr")
    split = tmp_path / "mini.txt"
    split.write_text(f"{box_capture_path} boxes\nother.zarr\nmissing.zarr\n")
    out = tmp_path / "runs"
    state = rescene_split(str(split), str(out), deployment=None, return_state=True)
    assert state.is_failed() and "missing (Failed: capture not found" in state.message
    rows = pq.read_table(out / "mini_summary.parquet").to_pylist()
    assert [(r["scene"], r["state"], r["skipped"]) for r in rows] == [
        ("boxes", "Completed", False),
        ("other", "Completed", False),
        ("missing", "Failed", False),
    ]
    assert rows[0]["instances"] == 3 and rows[2]["message"] == f"capture not found: {tmp_path / 'missing.zarr'}"
    md = (out / "mini_summary.md").read_text()
    assert "3 scenes: 2 completed (0 skipped as done), 1 failed, 0 timed out" in md and "| missing | Failed |" in md
    assert fake_stages["asset"] == 6

    # rerun (as after a crash): the done scenes are skipped without running a stage
    fake_stages.clear()
    (out / "other" / "manifest.json").unlink()  # as if the process died before 'other' finished
    state = rescene_split(str(split), str(out), deployment=None, return_state=True)
    rows = pq.read_table(out / "mini_summary.parquet").to_pylist()
    assert [(r["scene"], r["state"], r["skipped"]) for r in rows] == [
        ("boxes", "Completed", True),
        ("other", "Completed", False),
        ("missing", "Failed", False),
    ]
    assert sum(fake_stages.values()) == 0, dict(fake_stages)  # 'other' ran again, every task from the cache
    assert other.exists()

    # a changed config is not done
    fake_stages.clear()
    config = RunConfig().with_overrides(["registration.scale_max=1.2"])
    split.write_text(f"{box_capture_path} boxes\n")
    state = rescene_split(str(split), str(out), deployment=None, config=config, return_state=True)
    assert state.is_completed(), state.message
    assert pq.read_table(out / "mini_summary.parquet").to_pylist()[0]["skipped"] is False
    assert fake_stages["registration"] == 3


def test_split_wait_times_out(prefect_server, box_capture_path, tmp_path, request):
    """A scene whose deployment run no worker takes is TimedOut after timeout_s; the split still reports."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.actions import WorkPoolCreate

    from deployments.deploy import register
    from flows.split import rescene_split

    with get_client(sync_client=True) as client:
        client.create_work_pool(WorkPoolCreate(name="no-workers", type="process"), overwrite=True)
    spec = {"name": "idle", "entrypoint": "flows/scene.py:rescene", "work_pool": {"name": "no-workers"}}
    deployment_id = register(spec)
    request.addfinalizer(lambda: _delete_deployment(deployment_id))  # the server is shared by the deployment tests
    with get_client(sync_client=True) as client:
        # workers run the flow in this tree, not in a copy of it (the copy includes the virtual environment)
        steps = client.read_deployment(deployment_id).pull_steps
    assert steps == [{"prefect.deployments.steps.set_working_directory": {"directory": str(Path.cwd().resolve())}}]
    split = tmp_path / "idle.txt"
    split.write_text(f"{box_capture_path} boxes\n")
    out = tmp_path / "runs"
    state = rescene_split(
        str(split), str(out), deployment="rescene/idle", timeout_s=2.0, poll_interval_s=0.5, return_state=True
    )
    assert state.is_failed() and "boxes (TimedOut: not final after 2 s" in state.message
    row = pq.read_table(out / "idle_summary.parquet").to_pylist()[0]
    assert row["state"] == "TimedOut" and row["flow_run_id"]


def test_a_scene_whose_run_cannot_be_created_fails_alone(prefect_server, box_capture_path, tmp_path):
    """The API refusing one scene's deployment run (here: no such deployment) fails that scene with the
    API's reason; the split still writes its summary."""
    from flows.split import rescene_split

    split = tmp_path / "nodeploy.txt"
    split.write_text(f"{box_capture_path} boxes\nmissing.zarr\n")
    out = tmp_path / "runs"
    state = rescene_split(str(split), str(out), deployment="rescene/no-such-deployment", return_state=True)
    assert state.is_failed() and "boxes (Failed: could not submit a rescene/no-such-deployment run" in state.message
    rows = pq.read_table(out / "nodeploy_summary.parquet").to_pylist()
    assert [(r["scene"], r["state"]) for r in rows] == [("boxes", "Failed"), ("missing", "Failed")]
    assert rows[0]["flow_run_id"] is None and "ObjectNotFound" in rows[0]["message"]


def _delete_deployment(deployment_id) -> None:
    from prefect.client.orchestration import get_client

    with get_client(sync_client=True) as client:
        client.delete_deployment(deployment_id)
