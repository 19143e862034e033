"""Shared fixtures. Prefect runs against a throwaway home, and convex decompositions are cached in a
throwaway directory (shared by every test and subprocess of the session, so a mesh is decomposed once),
so tests never touch a user's profile or ~/.cache and run as on a fresh machine.

Tests that need a Prefect API share one real `prefect server start` (``prefect_api``) per test process
(`make test` runs two, pytest-xdist), started in the background once the tests are collected and stopped
after the last of them: starting a server (imports and database migrations) costs as much as a small test,
and a command-line run without one would start a temporary server of its own."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

import pytest


def _throwaway_dir(variable: str, prefix: str) -> None:
    """Point ``variable`` at a fresh temporary folder, removed when the test process exits, unless the caller
    set it (a folder the caller chose is theirs to keep)."""
    if variable in os.environ:
        return
    path = tempfile.mkdtemp(prefix=prefix)
    os.environ[variable] = path
    atexit.register(shutil.rmtree, path, ignore_errors=True)


os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
_throwaway_dir("PREFECT_HOME", "rescene-prefect-home-")
_throwaway_dir("RESCENE_CACHE_DIR", "rescene-cache-")


@pytest.fixture
def fake_stages(monkeypatch):
    """Replace every stage library call in ``rescene_core.stages.calls`` by the counting fakes of tests/flows/fakes.py
    (flow tests under the Prefect test server, task tests through ``task.fn()``)."""
    from rescene_core.stages import calls as stages
    from tests.flows import fakes

    for name, fn in fakes.STAGE_FAKES.items():
        monkeypatch.setattr(stages, name, fn)
    fakes.CALLS.clear()
    return fakes.CALLS


@pytest.fixture(scope="session")
def box_capture_path(tmp_path_factory):
    """The fakes' box capture, written once per session."""
    from tests.flows.fakes import box_capture

    return box_capture(tmp_path_factory.mktemp("capture") / "boxes.zarr")


@pytest.fixture(scope="session")
def prefect_api(request):
    """A real `prefect server start` on a free port (its own home and SQLite database) for every test that
    needs a Prefect API: the environment that points clients, the CLI and workers at it (``PREFECT_API_URL``).
    It starts in the background as soon as the tests are collected (``pytest_collection_finish``)."""
    from tests.flows.prefect_server import session_server, stop_after_last_use

    return stop_after_last_use(request).enter_context(session_server())


def pytest_collection_finish(session):
    from tests.flows.prefect_server import note_last_uses, start_session_server

    note_last_uses(session.items)
    if not session.config.option.collectonly and any(
        "prefect_api" in getattr(i, "fixturenames", ()) for i in session.items
    ):
        start_session_server()  # its imports and database migrations run alongside the first tests


@pytest.hookimpl(hookwrapper=True, trylast=True)
def pytest_runtest_teardown(item, nextitem):
    yield
    from tests.flows.prefect_server import stop_unused_after

    stop_unused_after(item)


def pytest_sessionfinish(session):
    from tests.flows.prefect_server import stop_session_server

    stop_session_server()  # started but not used (every test that needed it deselected or skipped)
