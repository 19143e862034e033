"""The flow holds its run directory (RUN/.lock) from before the first stage to the end of the run: a run
on a directory in use is refused before any stage, naming the holder; the lock of a dead process is taken
over; the lock is released after a completed and after a failed run."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time

import pytest

from rescene_core.config import RunConfig
from rescene_core.paths import RunPaths
from rescene_core.runlock import LOCK_FORMAT, read_lock
from rescene_core.stages import calls as stages
from rescene_core.stages.execution import FAULTS_FILE


def _foreign_lock(run_dir, pid: int, flow_run_id: str = "another-flow-run") -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    RunPaths(run_dir).lock.write_text(
        json.dumps(
            {
                "format": LOCK_FORMAT,
                "host": socket.gethostname(),
                "pid": pid,
                "started": "2026-11-27T09:30:00+00:00",
                "started_s": time.time(),
                "flow_run_id": flow_run_id,
                "boot_id": None,
                "token": "foreign",
            }
        )
    )


def test_run_on_a_directory_in_use_is_refused(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import run_flow

    run = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        _foreign_lock(run, holder.pid)
        state = run_flow(box_capture_path, run, RunConfig())
        assert state.is_failed()
        assert "RunDirectoryBusy" in state.message
        assert f"host {socket.gethostname()}, pid {holder.pid}, since 2026-11-27T09:30:00+00:00" in state.message
        assert sum(fake_stages.values()) == 0, dict(fake_stages)
        assert read_lock(RunPaths(run).lock).token == "foreign"  # the holder's lock is left as it was
        assert sorted(p.name for p in run.iterdir()) == [".lock"]  # nothing written beside it
    finally:
        holder.kill()
        holder.wait()


def test_lock_held_during_the_run_and_released(prefect_server, fake_stages, box_capture_path, tmp_path, monkeypatch):
    """A stage sees the lock of this flow run; after the run the directory is free. A lock left by a
    process that died is taken over."""
    from flows.scene import run_flow

    run = tmp_path / "run"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    _foreign_lock(run, dead.pid)
    seen = []
    shell = stages.estimate_shell

    def watching_shell(capture, config):
        seen.append(read_lock(RunPaths(run).lock))
        return shell(capture, config)

    monkeypatch.setattr(stages, "estimate_shell", watching_shell)
    state = run_flow(box_capture_path, run, RunConfig())
    assert state.is_completed(), state.message
    manifest = json.loads((run / "manifest.json").read_text())
    assert len(seen) == 1 and seen[0] is not None
    assert (seen[0].pid, seen[0].flow_run_id) == (os.getpid(), manifest["flow_run_id"])
    assert seen[0].took_over is not None and seen[0].took_over["pid"] == dead.pid
    assert not RunPaths(run).lock.exists()


def test_lock_released_after_a_failed_run(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import run_flow

    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "asset", "item": 3, "kind": "bad_input", "times": 1}]))
    state = run_flow(box_capture_path, run, RunConfig())
    assert state.is_failed() and "3" in state.message
    assert not RunPaths(run).lock.exists()
    again = run_flow(box_capture_path, run, RunConfig())  # the directory is free for the retry
    assert again.is_completed(), again.message
    assert not RunPaths(run).lock.exists()


def test_retried_flow_run_takes_over_its_earlier_attempts_lock(prefect_server, fake_stages, box_capture_path, tmp_path):
    """`prefect flow-run retry` runs the flow function again under the same flow run id: the lock its
    earlier attempt left, held by a process still alive, is its own and taken over."""
    import asyncio
    from pathlib import Path

    from prefect.cli.flow_run import retry

    from flows.scene import run_flow

    run = tmp_path / "run"
    run.mkdir()
    (run / FAULTS_FILE).write_text(json.dumps([{"stage": "registration", "item": 3, "kind": "bad_input", "times": 1}]))
    state = run_flow(box_capture_path, run, RunConfig())
    assert state.is_failed()
    flow_run_id = str(state.state_details.flow_run_id)
    earlier = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        _foreign_lock(run, earlier.pid, flow_run_id=flow_run_id)
        entrypoint = f"{Path(__file__).resolve().parents[2] / 'flows' / 'scene.py'}:rescene"
        with pytest.raises(SystemExit) as exit_info:
            asyncio.run(retry(flow_run_id, entrypoint=entrypoint))
        assert exit_info.value.code in (0, None)
    finally:
        earlier.kill()
        earlier.wait()
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["state"] == "Completed" and manifest["flow_run_id"] == flow_run_id
    assert not RunPaths(run).lock.exists()
