"""Several workers sharing one server, as on a pool of GPU boxes: a Prefect server on a real PostgreSQL,
two process workers on one pool, and a split of six captures scheduled through ``rescene/scene``. The runs
are spread over both workers (each worker's own log names the flow runs it started), the VLM limit of 1
holds across them (each relation request timed inside the flow-run processes), every scene completes."""

from __future__ import annotations

import json
import shutil
import time
from datetime import datetime

import pyarrow.parquet as pq
import pytest

from rescene_core.config import RunConfig
from tests.ops.helpers import max_overlap

SCENES = 6


@pytest.mark.slow
@pytest.mark.drill
@pytest.mark.timeout(600)
def test_split_of_six_on_two_workers_over_postgres(pg_stack, box_capture_path):
    import httpx

    from flows.split import rescene_split
    from tests.flows.prefect_server import client_settings

    api, tmp = pg_stack["api"], pg_stack["tmp"]
    began = time.time()  # the stack's earlier drills logged their requests too
    assert httpx.get(f"{api}/admin/version", timeout=10).status_code == 200
    assert "postgresql+asyncpg://" in pg_stack["url"]
    captures = tmp / "captures"
    lines = []
    for k in range(SCENES):
        shutil.copytree(box_capture_path, captures / f"scene{k}.zarr")
        lines.append(f"captures/scene{k}.zarr")
    split = tmp / "six.txt"
    split.write_text("\n".join(lines) + "\n")
    # the openai backend makes the relation stage hold a slot of RESCENE_VLM_LIMIT around each request
    # (the simulation exports are left out: the drill is about the orchestration, not the scene)
    config = RunConfig().with_overrides(
        ["scenegraph.backend=openai", "scenegraph.vlm.base_url=http://127.0.0.1:9/v1", "export.simulation=false"]
    )
    with client_settings(api):
        state = rescene_split(
            str(split), str(tmp / "runs"), deployment="rescene/scene", config=config, poll_interval_s=1.0,
            timeout_s=400, return_state=True,
        )  # fmt: skip
    assert state.is_completed(), (state.message, (tmp / "worker-a.log").read_text()[-2000:])
    rows = pq.read_table(tmp / "runs" / "six_summary.parquet").to_pylist()
    assert [r["state"] for r in rows] == ["Completed"] * SCENES and not any(r["skipped"] for r in rows)
    for r in rows:
        manifest = json.loads((tmp / "runs" / r["scene"] / "manifest.json").read_text())
        assert manifest["state"] == "Completed" and manifest["stages"]["registration"] == {"completed": 3}

    # spread: each worker started some of the six flow runs, and no run was started twice (a worker that
    # finds a run already claimed by the other is refused by the server: "Ready to submit ...: False")
    started = {}
    for name in ("worker-a", "worker-b"):
        log = (tmp / f"{name}.log").read_text(errors="replace")
        started[name] = {r["flow_run_id"] for r in rows if f"Ready to submit {r['flow_run_id']}: True" in log}
    assert started["worker-a"] and started["worker-b"], started
    assert started["worker-a"] | started["worker-b"] == {r["flow_run_id"] for r in rows}
    assert not started["worker-a"] & started["worker-b"]

    # the shared VLM limit: 2 key frames x 6 scenes, never more than 1 request at once across all processes
    calls = [c for p in pg_stack["calls"].iterdir() if (c := json.loads(p.read_text()))["start"] >= began]
    assert len(calls) == 2 * SCENES
    assert len({c["pid"] for c in calls}) >= 2
    assert max_overlap([(c["start"], c["end"]) for c in calls]) == 1
    # ... while the flow runs themselves overlapped (the server's records), so the limit had work to do
    spans = []
    for r in rows:
        run = httpx.get(f"{api}/flow_runs/{r['flow_run_id']}", timeout=10).json()
        spans.append((datetime.fromisoformat(run["start_time"]), datetime.fromisoformat(run["end_time"])))
    assert max_overlap(spans) >= 2, spans
