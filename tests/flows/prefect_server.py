"""A real Prefect server on a free port for the deployment tests: its environment, the `prefect` CLI, and
start/stop of the server and workers as subprocesses.

The server and worker run with Prefect's own settings except where a test would only wait: the worker
asks for scheduled runs every 2 s (``PREFECT_WORKER_QUERY_SECONDS``, 10 s by default) and logs at
debug level (where it says when a flow run's slot is free again), and the server's scheduler service is
off, so the split deployment's nightly cron never starts a run in the middle of a test."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[2]
PREFECT = str(Path(sys.executable).parent / "prefect")
POOL = "rescene-local"

SERVER_ENV = {"PREFECT_SERVER_SERVICES_SCHEDULER_ENABLED": "false"}
WORKER_ENV = {"PREFECT_WORKER_QUERY_SECONDS": "2", "PREFECT_WORKER_DEBUG_MODE": "true"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def prefect_cli(args: list[str], env: dict[str, str], timeout: float = 300) -> subprocess.CompletedProcess:
    """Run `prefect ARGS` from the repository root; fails the test with its output when it fails."""
    out = subprocess.run([PREFECT, *args], env=env, cwd=REPO, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, f"prefect {' '.join(args)} failed:\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}"
    return out


def stop(*procs: subprocess.Popen | None) -> None:
    """Terminate each process, killing it when it does not exit within 30 s."""
    for proc in procs:
        if proc is not None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


@contextmanager
def local_server(tmp: Path, extra_env: dict[str, str] | None = None, timeout: float = 180) -> Iterator[dict[str, str]]:
    """A Prefect server with its own home and SQLite database under ``tmp`` (its output in server.log there);
    yields the environment that points the CLI, workers and clients at it (``PREFECT_API_URL``), and stops
    the server on exit."""
    port = free_port()
    api = f"http://127.0.0.1:{port}/api"
    env = {
        **os.environ,
        "PREFECT_HOME": str(tmp / "prefect-home"),
        "PREFECT_API_DATABASE_CONNECTION_URL": f"sqlite+aiosqlite:///{tmp / 'prefect.db'}",
        "PREFECT_SERVER_ANALYTICS_ENABLED": "false",
        "PREFECT_UI_ENABLED": "false",
        "OMP_NUM_THREADS": "1",
        **SERVER_ENV,
        **(extra_env or {}),
    }
    env.pop("PREFECT_API_URL", None)
    with open(tmp / "server.log", "w") as log:
        server = subprocess.Popen(
            [PREFECT, "server", "start", "--host", "127.0.0.1", "--port", str(port)],
            env=env, cwd=tmp, stdout=log, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        deadline = time.monotonic() + timeout
        while True:
            assert server.poll() is None, "prefect server exited"
            try:
                if httpx.get(f"{api}/health", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            assert time.monotonic() < deadline, f"prefect server at {api} did not become healthy in {timeout} s"
            time.sleep(1)
        yield {**env, "PREFECT_API_URL": api}
    finally:
        stop(server)


def start_worker(env: dict[str, str], log: Path, limit: int = 2) -> subprocess.Popen:
    """A process worker on the pool ``POOL`` of the server ``env`` points at, its output in ``log``."""
    with open(log, "w") as out:
        return subprocess.Popen(
            [PREFECT, "worker", "start", "--pool", POOL, "--limit", str(limit)],
            env={**env, **WORKER_ENV}, cwd=REPO, stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip


def wait_slot_released(log: Path, flow_run_id: str, timeout: float = 120) -> None:
    """Wait until the worker logging to ``log`` has let go of the flow run (its process ended and its
    slot is free). A flow run sent back to Scheduled before that is refused by the worker (Prefect's
    limiter takes one slot per flow run id), which would stop it."""
    line = f"Limit slot released for flow run '{flow_run_id}'"
    deadline = time.monotonic() + timeout
    while line not in log.read_text(errors="replace"):
        assert time.monotonic() < deadline, f"worker still holds flow run {flow_run_id} after {timeout} s"
        time.sleep(0.2)
