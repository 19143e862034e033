"""The `rescene` flow with the stage libraries replaced by counting fakes: run directory, caching,
per-instance failures, retries, run log and artifacts."""

from __future__ import annotations

import json

import pytest

from rescene_core.config import RunConfig
from rescene_core.runlog import read_messages
from rescene_core.stages.execution import FAULTS_FILE


def _run(capture, run_dir, config=None):
    from flows.scene import run_flow

    return run_flow(capture, run_dir, config or RunConfig())


def test_flow_writes_run_directory_and_caches(prefect_server, fake_stages, box_capture_path, tmp_path):
    run = tmp_path / "run"
    state = _run(box_capture_path, run)
    assert state.is_completed(), state.message
    for rel in ("manifest.json", "config.yaml", "shell.json", "keyframes.json", "layout.json", "logs/run.mcap",
                "scene/scene.glb", "scene/scene.json", "scenegraph/graph.json"):  # fmt: skip
        assert (run / rel).exists(), rel
    for i in (2, 3, 4):
        for name in ("view.json", "asset.json", "asset.glb", "pose.json"):
            assert (run / "instances" / str(i) / name).exists()
    first = dict(fake_stages)
    assert first == {"shell": 1, "view": 1, "asset": 3, "registration": 3, "keyframes": 1, "relations": 2,
                     "fusion": 1, "attachment": 1}  # fmt: skip
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["state"] == "Completed" and manifest["missing"] == []
    import pyarrow.parquet as pq

    table = pq.read_table(run / "instances.parquet").to_pylist()
    assert [(r["instance"], r["registration"]) for r in table] == [(2, "ok"), (3, "ok"), (4, "ok")]
    assert manifest["stages"]["registration"] == {"completed": 3}

    # a second identical run executes no stage
    fake_stages.clear()
    state = _run(box_capture_path, run)
    assert state.is_completed()
    assert sum(fake_stages.values()) == 0, dict(fake_stages)
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["stages"]["registration"] == {"cached": 3}
    assert manifest["stages"]["export"] == {"cached": 1}

    # one registration parameter changed: registration and what follows re-run, nothing before it
    fake_stages.clear()
    config = RunConfig().with_overrides(["registration.scale_max=1.2"])
    state = _run(box_capture_path, run, config)
    assert state.is_completed()
    # fusion takes the predictions and the missing set, not the poses: it stays cached
    assert dict(fake_stages) == {"registration": 3, "attachment": 1}
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["stages"]["view"] == {"cached": 1} and manifest["stages"]["asset"] == {"cached": 3}
    assert manifest["stages"]["fusion"] == {"cached": 1} and manifest["stages"]["export"] == {"completed": 1}
    scene = json.loads((run / "scene/scene.json").read_text())
    assert [o["node"] for o in scene["objects"]] == ["obj_2_box", "obj_3_box", "obj_4_box"]
    assert scene["objects"][0]["scale"] == pytest.approx(0.6 * 1.2, rel=0.05)


def test_a_changed_mjcf_reruns_the_physics_check(prefect_server, fake_stages, box_capture_path, tmp_path):
    """The wall boxes' thickness changes the MJCF and the GLB, not scene.json: the physics check and the
    evaluation that read those files run again (the export's reference covers every file under scene/)."""
    run = tmp_path / "run"
    assert _run(box_capture_path, run).is_completed()
    mjcf = (run / "scene/mjcf/scene.xml").read_bytes()
    scene_json = (run / "scene/scene.json").read_bytes()
    config = RunConfig().with_overrides(["export.wall_thickness=0.12"])
    assert _run(box_capture_path, run, config).is_completed()
    assert (run / "scene/scene.json").read_bytes() == scene_json and (run / "scene/mjcf/scene.xml").read_bytes() != mjcf
    stages = json.loads((run / "manifest.json").read_text())["stages"]
    assert stages["export"] == {"completed": 1} and stages["attachment"] == {"cached": 1}
    assert stages["simcheck"] == {"completed": 1} and stages["evaluation"] == {"completed": 1}


def test_run_log_has_every_channel(prefect_server, fake_stages, box_capture_path, tmp_path):
    run = tmp_path / "run"
    assert _run(box_capture_path, run).is_completed()
    messages = read_messages(run / "logs/run.mcap")
    topics = {t for t, _, _ in messages}
    for topic in ("/flow/events", "/flow/tasks", "/task/events", "/hierview/view_scores", "/registration/gates",
                  "/scenegraph/frame_predictions", "/scenegraph/fusion", "/assembly/operations", "/metrics",
                  "/scene/after_registration", "/scene/after_attachment"):  # fmt: skip
        assert topic in topics, topic
    from mcap.reader import make_reader

    with open(run / "logs/run.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    names = {s.name for s in summary.schemas.values()}
    assert "foxglove.SceneUpdate" in names
    assert all(c.message_encoding == "json" for c in summary.channels.values())
    update = next(m for t, _, m in messages if t == "/scene/after_attachment")
    ids = {e["id"] for e in update["entities"]}
    assert {"obj_2_box", "obj_3_box", "obj_4_box", "shell_floor"} <= ids
    obj = next(e for e in update["entities"] if e["id"] == "obj_2_box")
    assert obj["triangles"][0]["indices"] and obj["cubes"][0]["size"]["x"] > 0


def test_bad_input_fails_instance_without_retry(prefect_server, fake_stages, box_capture_path, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "asset", "item": 3, "kind": "bad_input", "times": 5}]))
    state = _run(box_capture_path, run)
    assert state.is_failed()
    assert "instances failed: 3" in state.message
    assert fake_stages["asset"] == 2  # the faulty instance never reached the library, and was tried once
    assert (run / ".faults/asset-000003.count").read_text().strip() == "1"
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["failed_instances"] == [3]
    assert manifest["missing"][0]["stage"] == "asset"
    scene = json.loads((run / "scene/scene.json").read_text())
    assert [o["instance"] for o in scene["objects"]] == [2, 4]  # assembled from the rest


def test_transient_fault_is_retried(prefect_server, fake_stages, box_capture_path, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "registration", "item": 2, "kind": "transient", "times": 2}]))
    state = _run(box_capture_path, run)
    assert state.is_completed(), state.message
    assert (run / ".faults/registration-000002.count").read_text().strip() == "2"
    assert fake_stages["registration"] == 3


def test_missing_stage_is_reported(prefect_server, box_capture_path, tmp_path, monkeypatch):
    from rescene_core.stages import calls as stages

    def unavailable(*args, **kwargs):
        raise stages.StageNotAvailable("shell", "rescene_core.shell")

    monkeypatch.setattr(stages, "estimate_shell", unavailable)
    monkeypatch.setattr(stages, "select_views", unavailable)
    state = _run(box_capture_path, tmp_path / "run")
    assert state.is_failed()
    assert "is not available" in state.message


def test_flow_run_retry_reruns_only_failed_instances(prefect_server, fake_stages, box_capture_path, tmp_path):
    """`prefect flow-run retry` after an instance failed: only that instance and what follows it run."""
    import asyncio
    from pathlib import Path

    from prefect.cli.flow_run import retry
    from prefect.client.orchestration import get_client

    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "registration", "item": 3, "kind": "bad_input", "times": 1}]))
    state = _run(box_capture_path, run)
    assert state.is_failed() and "instances failed: 3" in state.message
    assert fake_stages["registration"] == 2
    flow_run_id = state.state_details.flow_run_id

    fake_stages.clear()
    entrypoint = f"{Path(__file__).resolve().parents[2] / 'flows' / 'scene.py'}:rescene"
    with pytest.raises(SystemExit) as exit_info:
        asyncio.run(retry(str(flow_run_id), entrypoint=entrypoint))
    assert exit_info.value.code in (0, None)
    assert dict(fake_stages) == {"registration": 1, "fusion": 1, "attachment": 1}

    async def final_state():
        async with get_client() as client:
            return (await client.read_flow_run(flow_run_id)).state

    assert asyncio.run(final_state()).is_completed()
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["failed_instances"] == [] and manifest["stages"]["registration"] == {"cached": 2, "completed": 1}
    assert [o["instance"] for o in json.loads((run / "scene/scene.json").read_text())["objects"]] == [2, 3, 4]


def test_bad_capture_fails_with_every_problem(prefect_server, fake_stages, tmp_path):
    import zarr

    from tests.flows.fakes import box_capture

    capture = box_capture(tmp_path / "bad.zarr")
    root = zarr.open_group(str(capture), mode="r+")
    root.attrs["format"] = "something-else"
    state = _run(capture, tmp_path / "run")
    assert state.is_failed()
    assert "problem(s) in the capture" in state.message and "format" in state.message
    assert sum(fake_stages.values()) == 0


def test_artifacts_report_table_progress(prefect_server, fake_stages, box_capture_path, tmp_path):
    import httpx
    from prefect.settings import PREFECT_API_URL

    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "registration", "item": 4, "kind": "bad_input", "times": 1}]))
    state = _run(box_capture_path, run)
    flow_run_id = str(state.state_details.flow_run_id)

    # the REST API directly: Prefect 3.8.8's client sends null limit/sort, which the server rejects
    body = {
        "artifacts": {"flow_run_id": {"any_": [flow_run_id]}},
        "limit": 50,
        "offset": 0,
        "sort": "CREATED_DESC",
    }
    found = httpx.post(f"{PREFECT_API_URL.value()}/artifacts/filter", json=body, timeout=30).raise_for_status().json()
    by_type = {a["type"]: a for a in found}
    assert set(by_type) == {"markdown", "table", "progress"}
    assert by_type["progress"]["data"] == 100.0
    report = by_type["markdown"]["data"]
    assert "**Failed**" in report and "4 (registration)" in report
    table = by_type["table"]["data"]
    rows = json.loads(table) if isinstance(table, str) else table
    assert [(r["instance"], r["registration"], r["missing_stage"]) for r in rows] == [
        (2, "ok", ""),
        (3, "ok", ""),
        (4, "missing", "registration"),
    ]
