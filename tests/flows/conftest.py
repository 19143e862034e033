"""Flow tests run their flows in this process against the session's Prefect server (``prefect_api``, a real
`prefect server start`); the deployment tests share it with one process worker. The client settings and
the worker stop after the last test that uses them."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("RESCENE_RETRY_DELAY_S", "0.2")


@pytest.fixture(scope="session")
def prefect_server(prefect_api, request):
    """This process's Prefect client pointed at the session's server (SQLite in a temp dir), as
    ``prefect_test_harness`` points it at its own; flows called here run against it."""
    from tests.flows.prefect_server import client_settings, stop_after_last_use

    stop_after_last_use(request).enter_context(client_settings(prefect_api["PREFECT_API_URL"]))


@pytest.fixture(scope="session")
def deploy_stack(prefect_api, tmp_path_factory, request):
    """The process pool on the session's server and one process worker on it, shared by the deployment
    tests (each registers the deployments itself, as an operator would). The environment that points
    clients at the server, a temp dir and the worker's log."""
    from tests.flows.prefect_server import POOL, prefect_cli, start_worker, stop, stop_after_last_use

    tmp = tmp_path_factory.mktemp("prefect-stack")
    env = prefect_api
    prefect_cli(["work-pool", "create", POOL, "--type", "process", "--overwrite"], env, timeout=240)
    worker = start_worker(env, tmp / "worker.log")
    stop_after_last_use(request).callback(stop, worker)
    return {"env": env, "api": env["PREFECT_API_URL"], "tmp": tmp, "worker_log": tmp / "worker.log"}
