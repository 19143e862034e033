"""Crash drills on the PostgreSQL-backed server with two process workers (``pg_stack``), probed from
outside: kill -9 of the worker that runs a flow run, and a server restart, each in the middle of the run
(registration held by the drill's hook, shell, views and assets done). What must hold: the server learns
of the crash (heartbeats stop: the documented automation sets the run Crashed), a retry completes on the
other worker, and every task that had finished (its cache record written) is served from the cache, not
run again."""

from __future__ import annotations

import os
import signal

import httpx
import pytest

from tests.flows.prefect_server import post_retrying, wait_slot_released
from tests.ops.helpers import (
    HEARTBEAT_S,
    UI_RETRY,
    claimed_by,
    create_scene_run,
    flow_run_state,
    restart_server,
    stage_counts,
    trusted_records,
    wait_final,
    wait_until,
)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _held_run(pg_stack, capture, name: str):
    """A flow run of rescene/scene that stops in registration until its hold file goes: (flow run id, run
    directory, hold file, pid of the flow run's process), once it got there."""
    drill = pg_stack["tmp"] / name
    drill.mkdir()
    hold = drill / "hold"
    hold.touch()
    run_dir = drill / "run"
    flow_run_id = create_scene_run(pg_stack["api"], capture, run_dir, {"RESCENE_TEST_HOLD": str(hold)})
    reached = wait_until(f"{name}: registration reached", lambda: sorted(drill.glob("hold.reached-*")), 300)
    return flow_run_id, run_dir, hold, int(reached[0].name.rsplit("-", 1)[1])


def _check_resumed_from_cache(run_dir, trusted) -> None:
    """The finished run served every task that had a cache record at the fault from the cache, and ran the rest."""
    stages = stage_counts(run_dir)
    for stage, counts in stages.items():
        assert counts.get("cached", 0) == trusted[stage], (stage, counts, dict(trusted))
    assert trusted["shell"] == 1 and trusted["asset"] >= 1
    assert stages["registration"] == {"completed": 3}
    assert trusted_records(run_dir)[1] == []


@pytest.mark.slow
@pytest.mark.drill
@pytest.mark.timeout(600)
def test_worker_killed_mid_run_is_crashed_and_retried_on_the_other(pg_stack, box_capture_path):
    api, tmp = pg_stack["api"], pg_stack["tmp"]
    flow_run_id, run_dir, hold, flow_pid = _held_run(pg_stack, box_capture_path, "kill")
    (owner,) = claimed_by(tmp, flow_run_id)
    (other,) = {"worker-a", "worker-b"} - {owner}
    assert flow_run_state(api, flow_run_id)["type"] == "RUNNING"

    # kill -9 of the worker's process group, and of the flow run's process where it has a session of its own
    worker = pg_stack["workers"][owner]
    os.killpg(worker.pid, signal.SIGKILL)
    worker.wait(timeout=30)
    if _alive(flow_pid):
        os.killpg(os.getpgid(flow_pid), signal.SIGKILL)
    wait_until("flow run process gone", lambda: not _alive(flow_pid), 30)
    trusted, problems = trusted_records(run_dir)
    assert problems == []

    # nobody reports the end: the server marks the run Crashed once its heartbeats stop
    crashed = wait_final(api, flow_run_id, timeout=4 * HEARTBEAT_S + 60)
    assert crashed["type"] == "CRASHED", crashed
    assert (run_dir / ".lock").exists()  # left by the killed process; the retry takes it over

    hold.unlink()
    response = post_retrying(f"{api}/flow_runs/{flow_run_id}/set_state", json=UI_RETRY)
    assert response.status_code in (200, 201) and response.json()["status"] == "ACCEPT", response.text
    final = wait_final(api, flow_run_id, after=crashed["id"], timeout=300)
    assert final["type"] == "COMPLETED", (final, (tmp / f"{other}.log").read_text()[-3000:])
    assert claimed_by(tmp, flow_run_id) == sorted([owner, other])  # the retry ran on the other worker
    _check_resumed_from_cache(run_dir, trusted)
    wait_slot_released(tmp / f"{other}.log", flow_run_id)
    pg_stack["start_worker"](owner)  # back to two workers for the next drill


@pytest.mark.slow
@pytest.mark.drill
@pytest.mark.timeout(600)
def test_server_restarted_mid_run_resumes_or_retries_from_the_cache(pg_stack, box_capture_path):
    api, tmp = pg_stack["api"], pg_stack["tmp"]
    flow_run_id, run_dir, hold, _ = _held_run(pg_stack, box_capture_path, "restart")

    restart_server(pg_stack["server"])  # the flow run's process keeps running while the API is gone
    assert httpx.get(f"{api}/flow_runs/{flow_run_id}", timeout=10).json()["state"]["type"] == "RUNNING"
    hold.unlink()
    final = wait_final(api, flow_run_id, timeout=300)
    if final["type"] == "COMPLETED":  # resumed: every task ran once, in this one run
        names = [t["name"].rsplit("-", 1)[0] for t in _task_runs(api, flow_run_id)]
        assert {s: names.count(s) for s in ("shell", "view", "asset", "registration")} == {
            "shell": 1, "view": 1, "asset": 3, "registration": 3,
        }  # fmt: skip
        assert all("cached" not in c for c in stage_counts(run_dir).values())
    else:  # failed or crashed cleanly: the retry serves what had finished from the cache
        trusted, problems = trusted_records(run_dir)
        assert problems == []
        response = post_retrying(f"{api}/flow_runs/{flow_run_id}/set_state", json=UI_RETRY)
        assert response.status_code in (200, 201), response.text
        final = wait_final(api, flow_run_id, after=final["id"], timeout=300)
        assert final["type"] == "COMPLETED", final
        _check_resumed_from_cache(run_dir, trusted)
    for owner in claimed_by(tmp, flow_run_id):
        wait_slot_released(tmp / f"{owner}.log", flow_run_id)


def _task_runs(api: str, flow_run_id: str) -> list[dict]:
    """The task runs the server recorded for the flow run."""
    body = {"task_runs": {"flow_run_id": {"any_": [flow_run_id]}}, "limit": 200}
    return httpx.post(f"{api}/task_runs/filter", json=body, timeout=10).json()
