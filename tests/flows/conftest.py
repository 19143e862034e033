"""Flow tests share one Prefect test server (``prefect_test_harness``) for the whole session."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("RESCENE_RETRY_DELAY_S", "0.2")


@pytest.fixture(scope="session")
def prefect_server():
    """A throwaway Prefect API (SQLite in a temp dir) for every flow test of the session."""
    from prefect.testing.utilities import prefect_test_harness

    with prefect_test_harness(server_startup_timeout=60):
        yield
