"""RunLock: one run per run directory; the second is refused naming the holder, stale locks are taken over."""

from __future__ import annotations

import json
import logging
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rescene_core import runlock
from rescene_core.paths import RunPaths
from rescene_core.runlock import RunDirectoryBusy, acquire_run_directory, hold_run_directory, read_lock

REPO = Path(__file__).resolve().parents[1]


def _write_lock(run_dir: Path, **fields) -> dict:
    holder = {
        "format": runlock.LOCK_FORMAT,
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "started": "2026-11-27T10:00:00+00:00",
        "started_s": time.time(),
        "flow_run_id": None,
        "boot_id": runlock._boot_id(),
        "token": "earlier",
        **fields,
    }
    RunPaths(run_dir).lock.write_text(json.dumps(holder))
    return holder


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    assert not runlock.pid_alive(proc.pid)
    return proc.pid


def test_lock_written_then_released(tmp_path):
    with hold_run_directory(tmp_path, flow_run_id="run-a") as held:
        holder = read_lock(RunPaths(tmp_path).lock)
        assert holder == held.holder
        assert (holder.host, holder.pid, holder.flow_run_id) == (socket.gethostname(), os.getpid(), "run-a")
    assert not RunPaths(tmp_path).lock.exists()
    assert [p.name for p in tmp_path.iterdir()] == []  # no temporary or claim file left behind


def test_second_run_refused_naming_the_holder(tmp_path):
    with hold_run_directory(tmp_path, flow_run_id="run-a") as held:
        with pytest.raises(RunDirectoryBusy) as err:
            acquire_run_directory(tmp_path, flow_run_id="run-b")
        message = str(err.value)
        assert f"host {socket.gethostname()}, pid {os.getpid()}, since {held.holder.started}" in message
        assert "flow run run-a" in message and str(RunPaths(tmp_path).lock) in message
        assert err.value.holder == held.holder
        assert read_lock(RunPaths(tmp_path).lock) == held.holder  # the refused run left the lock alone


def test_second_process_refused(tmp_path):
    code = (
        "import sys\nfrom rescene_core.runlock import RunDirectoryBusy, acquire_run_directory\n"
        f"try:\n    acquire_run_directory({str(tmp_path)!r})\nexcept RunDirectoryBusy as e:\n"
        "    print(e); sys.exit(3)\n"
    )
    with hold_run_directory(tmp_path):
        out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == 3, out.stderr
    assert f"pid {os.getpid()}" in out.stdout and "in use by another run" in out.stdout


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="process states are read from /proc (Linux)")
def test_a_killed_process_not_yet_reaped_is_not_alive():
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        assert runlock.pid_alive(child.pid)
        child.kill()
        deadline = time.monotonic() + 10
        while Path(f"/proc/{child.pid}/stat").exists() and " Z " not in Path(f"/proc/{child.pid}/stat").read_text():
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert not runlock.pid_alive(child.pid)  # a zombie until waited for
    finally:
        child.wait()


def test_stale_lock_of_dead_process_taken_over_and_logged(tmp_path, caplog):
    dead = _dead_pid()
    _write_lock(tmp_path, pid=dead, flow_run_id="crashed")
    with caplog.at_level(logging.WARNING, logger="rescene_core.runlock"):
        with hold_run_directory(tmp_path, flow_run_id="fresh") as held:
            assert held.holder.pid == os.getpid()
            assert held.holder.took_over is not None and held.holder.took_over["pid"] == dead
            assert read_lock(RunPaths(tmp_path).lock).flow_run_id == "fresh"
    assert "no longer running" in caplog.text and f"pid {dead}" in caplog.text
    assert not RunPaths(tmp_path).lock.exists()


def test_same_flow_run_takes_over_its_own_lock(tmp_path):
    """A retried flow run runs the flow again, maybe in another process: its earlier attempt's lock,
    whose process is still alive here, is its own."""
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        _write_lock(tmp_path, pid=sleeper.pid, flow_run_id="flow-run-1")
        with pytest.raises(RunDirectoryBusy):
            acquire_run_directory(tmp_path, flow_run_id="flow-run-2")
        held = acquire_run_directory(tmp_path, flow_run_id="flow-run-1")
        assert held.holder.pid == os.getpid() and held.holder.took_over["pid"] == sleeper.pid
        held.release()
    finally:
        sleeper.kill()
        sleeper.wait()


def test_other_host_lock_stale_only_after_the_bound(tmp_path, monkeypatch):
    _write_lock(tmp_path, host="gpu-box-7", pid=1, started_s=time.time() - 600)
    with pytest.raises(RunDirectoryBusy, match="host gpu-box-7, pid 1") as err:
        acquire_run_directory(tmp_path)
    assert runlock.STALE_ENV in str(err.value)
    monkeypatch.setenv(runlock.STALE_ENV, "300")
    with hold_run_directory(tmp_path) as held:
        assert held.holder.took_over["host"] == "gpu-box-7"


def test_lock_from_before_a_reboot_is_stale(tmp_path):
    if runlock._boot_id() is None:
        pytest.skip("no boot id on this system")
    _write_lock(tmp_path, pid=os.getpid(), boot_id="another-boot")
    with hold_run_directory(tmp_path) as held:
        assert held.holder.took_over["boot_id"] == "another-boot"


def test_unreadable_lock_refused_until_the_bound(tmp_path):
    RunPaths(tmp_path).lock.write_text("{not json")
    with pytest.raises(RunDirectoryBusy, match="holds a lock that cannot be read"):
        acquire_run_directory(tmp_path)
    old = time.time() - 7200
    os.utime(RunPaths(tmp_path).lock, (old, old))
    with hold_run_directory(tmp_path, stale_s=3600) as held:
        assert held.holder.took_over["token"].startswith(runlock.UNREADABLE)


def test_released_only_by_its_holder(tmp_path):
    held = acquire_run_directory(tmp_path)
    replaced = _write_lock(tmp_path, token="someone-else")  # taken over meanwhile (e.g. judged stale)
    held.release()
    assert read_lock(RunPaths(tmp_path).lock).token == replaced["token"]


def test_released_when_the_block_raises(tmp_path):
    with pytest.raises(RuntimeError, match="stage failed"):
        with hold_run_directory(tmp_path):
            raise RuntimeError("stage failed")
    assert not RunPaths(tmp_path).lock.exists()


RACER = """
import sys, time
from rescene_core.runlock import RunDirectoryBusy, hold_run_directory
start = float(sys.argv[2])
while time.time() < start:
    time.sleep(0.001)
try:
    with hold_run_directory(sys.argv[1]):
        print("held", flush=True)
        time.sleep(1.0)  # hold it while the others try
except RunDirectoryBusy:
    print("busy")
"""


@pytest.mark.parametrize("stale", [False, True], ids=["fresh", "stale"])
def test_racing_processes_exactly_one_wins(tmp_path, stale):
    """Four processes start taking the lock at the same instant (on a free directory, or one whose lock
    is left by a dead process): exactly one holds it, the others are refused."""
    if stale:
        _write_lock(tmp_path, pid=_dead_pid())
    start = time.time() + 2.0
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", RACER, str(tmp_path), str(start)], cwd=REPO, stdout=subprocess.PIPE, text=True
        )
        for _ in range(4)
    ]
    outs = [p.communicate(timeout=60)[0].strip() for p in procs]
    assert sorted(outs) == ["busy", "busy", "busy", "held"], outs
    assert [p.name for p in tmp_path.iterdir()] == []  # released by the winner; no temporary or claim file left


def test_pipeline_refuses_a_directory_in_use(tmp_path):
    from rescene_core.pipeline import run_pipeline

    with hold_run_directory(tmp_path, flow_run_id="flow-run-1"):
        with pytest.raises(RunDirectoryBusy, match="flow run flow-run-1"):
            run_pipeline(tmp_path / "no-capture-read.zarr", out_dir=tmp_path)
