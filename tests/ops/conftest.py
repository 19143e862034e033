"""The fault drills. The cheap ones share the session's Prefect server with the flow tests
(``prefect_server``); those marked ``drill`` run a Prefect server on PostgreSQL with two process workers
(``pg_stack``) and wait out heartbeats and restarts (minutes): they run under ``make drills``
(``RESCENE_DRILLS=1``) and are skipped, with that reason, in ``make test``."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

from tests.flows.conftest import prefect_server  # noqa: F401 - the fixture, shared with tests/flows

os.environ.setdefault("RESCENE_RETRY_DELAY_S", "0.2")


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "drill: a fault drill over PostgreSQL and several workers (minutes); `make drills` runs it"
    )


def pytest_collection_modifyitems(config, items):
    if os.environ.get("RESCENE_DRILLS") == "1":
        return
    skip = pytest.mark.skip(reason="a fault drill over PostgreSQL and two workers (minutes): `make drills` runs it")
    for item in items:
        if item.get_closest_marker("drill") is not None:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def pg_stack(tmp_path_factory, request):
    """A real PostgreSQL (Debian's package, ``rescene_core.ops.postgres``) on a free port, a Prefect server on
    it, the process pool with the ``rescene/scene`` deployment, a global concurrency limit of 1 for the VLM
    (``RESCENE_VLM_LIMIT``), the automation that marks a flow run whose heartbeats stopped Crashed, and two
    process workers whose flow runs use the stage fakes, time each relation request and send heartbeats.
    Shared by the drills; stopped after the last of them."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.actions import GlobalConcurrencyLimitCreate, WorkPoolCreate

    from deployments.deploy import ensure_crash_detection, load_deployments, register
    from rescene_core.ops import postgres
    from tests.flows.prefect_server import (
        POOL,
        REPO,
        client_settings,
        free_port,
        start_server,
        stop,
        stop_after_last_use,
        wait_healthy,
    )
    from tests.ops.helpers import HEARTBEAT_S, fake_stage_env, start_named_worker

    try:
        postgres.bin_dir()
    except postgres.PostgresError as err:
        pytest.skip(str(err))
    if os.geteuid() == 0 and shutil.which("runuser") is None:
        pytest.skip("PostgreSQL refuses root and runuser (util-linux) is missing to run it as nobody")
    stack = stop_after_last_use(request)
    tmp = tmp_path_factory.mktemp("pg-stack")
    # the data directory where the unprivileged server user can reach it (pytest's temp dirs are 0700)
    pg_root = Path(tempfile.mkdtemp(prefix="rescene-pg-"))
    pg_root.chmod(0o711)
    stack.callback(shutil.rmtree, pg_root, True)
    url = postgres.start(pg_root / "data", free_port())
    stack.callback(postgres.stop, pg_root / "data")
    server = start_server(tmp, {"PREFECT_API_DATABASE_CONNECTION_URL": url})
    stack.callback(lambda: stop(server.process))
    env = wait_healthy(server)
    api = env["PREFECT_API_URL"]
    with client_settings(api), get_client(sync_client=True) as client:
        client.create_work_pool(WorkPoolCreate(name=POOL, type="process"), overwrite=True)
        client.create_global_concurrency_limit(GlobalConcurrencyLimitCreate(name="vlm-ops", limit=1))
        (scene,) = [d for d in load_deployments(REPO / "deployments" / "prefect.yaml") if d["name"] == "scene"]
        register(scene)
        assert ensure_crash_detection(HEARTBEAT_S + 15)
    calls = tmp / "vlm-calls"
    worker_env = {**env, **fake_stage_env(tmp, calls), "RESCENE_VLM_LIMIT": "vlm-ops"}
    worker_env["PREFECT_FLOWS_HEARTBEAT_FREQUENCY"] = str(HEARTBEAT_S)
    workers: dict[str, subprocess.Popen] = {}

    def start(name: str) -> subprocess.Popen:
        workers[name] = start_named_worker(worker_env, name, tmp / f"{name}.log")
        return workers[name]

    for name in ("worker-a", "worker-b"):
        start(name)
    stack.callback(lambda: stop(*workers.values()))
    return {"env": env, "api": api, "url": url, "tmp": tmp, "server": server, "workers": workers,
            "start_worker": start, "calls": calls, "worker_env": worker_env}  # fmt: skip
