"""Flow tests share one Prefect test server (``prefect_test_harness``); the deployment tests share one real
`prefect server start` with a process worker. Both live as long as the tests of this package (they stop
before the rest of the suite, which needs neither)."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("RESCENE_RETRY_DELAY_S", "0.2")


@pytest.fixture(scope="package")
def prefect_server():
    """A throwaway Prefect API (SQLite in a temp dir) for every flow test."""
    from prefect.testing.utilities import prefect_test_harness

    with prefect_test_harness(server_startup_timeout=60):
        yield


@pytest.fixture(scope="package")
def deploy_stack(tmp_path_factory):
    """A real `prefect server start` on a free port with the process pool and one process worker on it,
    shared by the deployment tests (each registers the deployments itself, as an operator would).
    Yields the environment that points clients at it, the temp dir and the worker's log."""
    from tests.flows.prefect_server import POOL, local_server, prefect_cli, start_worker, stop

    tmp = tmp_path_factory.mktemp("prefect-stack")
    with local_server(tmp) as env:
        worker = None
        try:
            prefect_cli(["work-pool", "create", POOL, "--type", "process", "--overwrite"], env, timeout=240)
            worker = start_worker(env, tmp / "worker.log")
            yield {"env": env, "api": env["PREFECT_API_URL"], "tmp": tmp, "worker_log": tmp / "worker.log"}
        finally:
            stop(worker)
