"""A real Prefect server on a free port for the deployment tests: its environment, the `prefect` CLI, and
start/stop of the server and workers as subprocesses.

The server and worker run with Prefect's own settings except where a test would only wait: the worker
asks for scheduled runs every 2 s (``PREFECT_WORKER_QUERY_SECONDS``, 10 s by default) and logs at
debug level (where it says when a flow run's slot is free again), and the server's scheduler service is
off, so the split deployment's nightly cron never starts a run in the middle of a test."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
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
    """Run `prefect ARGS` from the repository root; fails the test with its output when it fails (and, for a
    flow run that ended badly, with the flow run's own log: the worker's log does not hold its traceback)."""
    out = subprocess.run([PREFECT, *args], env=env, cwd=REPO, capture_output=True, text=True, timeout=timeout)
    if out.returncode != 0:
        run_log = ""
        run_id = re.search(r"UUID: ([0-9a-f-]{36})", out.stdout)
        if run_id:
            logs = subprocess.run(
                [PREFECT, "flow-run", "logs", run_id[1]], env=env, cwd=REPO, capture_output=True, text=True, timeout=60
            )
            run_log = f"\nflow run {run_id[1]} log:\n{logs.stdout[-6000:]}{logs.stderr[-1000:]}"
        raise AssertionError(f"prefect {' '.join(args)} failed:\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}{run_log}")
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


@dataclass
class Server:
    """A started `prefect server start` and the environment that points clients at it."""

    process: subprocess.Popen
    env: dict[str, str]
    log: Path


def start_server(tmp: Path, extra_env: dict[str, str] | None = None) -> Server:
    """Start a Prefect server with its own home and SQLite database under ``tmp`` (its output in server.log
    there), without waiting for it (``wait_healthy``)."""
    port = free_port()
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
        process = subprocess.Popen(
            [PREFECT, "server", "start", "--host", "127.0.0.1", "--port", str(port)],
            env=env, cwd=tmp, stdout=log, stderr=subprocess.STDOUT,
        )  # fmt: skip
    return Server(process, {**env, "PREFECT_API_URL": f"http://127.0.0.1:{port}/api"}, tmp / "server.log")


def wait_healthy(server: Server, timeout: float = 180) -> dict[str, str]:
    """Wait until ``server`` answers its health check; its environment (``PREFECT_API_URL`` set)."""
    api = server.env["PREFECT_API_URL"]
    deadline = time.monotonic() + timeout
    while True:
        assert server.process.poll() is None, f"prefect server exited:\n{server.log.read_text()[-3000:]}"
        try:
            if httpx.get(f"{api}/health", timeout=2).status_code == 200:
                return server.env
        except httpx.HTTPError:
            pass
        assert time.monotonic() < deadline, f"prefect server at {api} did not become healthy in {timeout} s"
        time.sleep(0.25)


@contextmanager
def local_server(tmp: Path, extra_env: dict[str, str] | None = None, timeout: float = 180) -> Iterator[dict[str, str]]:
    """A Prefect server (``start_server``): yields the environment that points the CLI, workers and clients
    at it (``PREFECT_API_URL``), and stops the server on exit."""
    server = start_server(tmp, extra_env)
    try:
        yield wait_healthy(server, timeout)
    finally:
        stop(server.process)


_SESSION_SERVER: list[Server] = []
"""The session's server (``start_session_server``), once started."""


def start_session_server() -> None:
    """Start the session's server in the background (its home and database in a new temp dir), so that it
    is up by the time the first test that needs it runs."""
    if not _SESSION_SERVER:
        _SESSION_SERVER.append(start_server(Path(tempfile.mkdtemp(prefix="rescene-prefect-server-"))))


@contextmanager
def session_server(timeout: float = 180) -> Iterator[dict[str, str]]:
    """The session's server (started now unless it already was): yields its environment once it is healthy
    and stops it on exit."""
    start_session_server()
    try:
        yield wait_healthy(_SESSION_SERVER[0], timeout)
    finally:
        stop_session_server()


def stop_session_server() -> None:
    """Stop the session's server if it was started and remove its temp dir (again: nothing)."""
    for server in _SESSION_SERVER:
        stop(server.process)
        shutil.rmtree(server.log.parent, ignore_errors=True)


@contextmanager
def client_settings(api: str) -> Iterator[None]:
    """Point this process's Prefect client at ``api`` (what ``prefect_test_harness`` does for its own server);
    on exit, send the logs and events still queued before the settings change back."""
    import inspect

    import prefect.context
    from prefect.events.worker import EventsWorker
    from prefect.logging.handlers import APILogWorker
    from prefect.settings import PREFECT_API_URL, temporary_settings
    from prefect.utilities.asyncutils import run_coro_as_sync

    async def drain() -> None:
        try:
            done = APILogWorker.instance().drain()
            if inspect.isawaitable(done):
                await done
        except RuntimeError:  # the log worker never started
            pass
        done = EventsWorker.drain_all()
        if inspect.isawaitable(done):
            await done

    with temporary_settings(updates={PREFECT_API_URL: api}):
        # also the process-global settings context, for contexts copied before this one (as the harness does)
        with prefect.context._temporary_global_settings_context(prefect.context.get_settings_context()):
            try:
                yield
            finally:
                run_coro_as_sync(drain())


def start_worker(env: dict[str, str], log: Path, limit: int = 2) -> subprocess.Popen:
    """A process worker on the pool ``POOL`` of the server ``env`` points at, its output in ``log``."""
    with open(log, "w") as out:
        return subprocess.Popen(
            [PREFECT, "worker", "start", "--pool", POOL, "--limit", str(limit)],
            env={**env, **WORKER_ENV}, cwd=REPO, stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip


_RUNNING: dict[str, ExitStack] = {}
"""Session fixtures that stop after their last test (``stop_after_last_use``), in the order they started."""
_LAST_USE: dict[str, str] = {}
"""Fixture name -> node id of the last collected test that uses it."""


def note_last_uses(items: Iterable) -> None:
    """Record, per fixture, the last of the collected tests ``items`` (in run order) that uses it."""
    for item in items:
        for name in getattr(item, "fixturenames", ()):
            _LAST_USE[name] = item.nodeid


def stop_after_last_use(request) -> ExitStack:
    """The resources of the session fixture ``request`` asks for: closed right after the last test that uses
    it (so a server or worker does not idle through the rest of the suite), or at the end of the session."""
    stack = ExitStack()
    _RUNNING[request.fixturename] = stack
    request.addfinalizer(stack.close)
    return stack


def stop_unused_after(item) -> None:
    """After ``item``'s teardown: close the fixtures it was the last user of, the later started first."""
    for name in reversed(list(_RUNNING)):
        if _LAST_USE.get(name) == item.nodeid:
            _RUNNING.pop(name).close()


def wait_slot_released(log: Path, flow_run_id: str, timeout: float = 120, times: int = 1) -> None:
    """Wait until the worker logging to ``log`` has let go of the flow run ``times`` times (its process
    ended and its slot is free). A flow run sent back to Scheduled before that is refused by the worker
    (Prefect's limiter takes one slot per flow run id), which would stop it; a worker stopped before that
    waits for the run's process and is killed after 30 s."""
    line = f"Limit slot released for flow run '{flow_run_id}'"
    deadline = time.monotonic() + timeout
    while log.read_text(errors="replace").count(line) < times:
        assert time.monotonic() < deadline, f"worker still holds flow run {flow_run_id} after {timeout} s"
        time.sleep(0.2)


def post_retrying(url: str, json: dict, attempts: int = 5, timeout: float = 10) -> httpx.Response:
    """POST ``json`` to ``url``, again after 503 Service Unavailable (the server's database busy under load,
    as Prefect's own client retries it), at most ``attempts`` times with a doubling pause from 0.5 s."""
    pause = 0.5
    for _ in range(attempts - 1):
        response = httpx.post(url, json=json, timeout=timeout)
        if response.status_code != 503:
            return response
        time.sleep(pause)
        pause *= 2
    return httpx.post(url, json=json, timeout=timeout)
