"""Shared fixtures. Prefect runs against a throwaway home, and convex decompositions are cached in a
throwaway directory (shared by every test and subprocess of the session, so a mesh is decomposed once),
so tests never touch a user's profile or ~/.cache and run as on a fresh machine."""

from __future__ import annotations

import os
import tempfile

import pytest

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_HOME", tempfile.mkdtemp(prefix="rescene-prefect-home-"))
os.environ.setdefault("RESCENE_CACHE_DIR", tempfile.mkdtemp(prefix="rescene-cache-"))


@pytest.fixture
def fake_stages(monkeypatch):
    """Replace every stage library call in ``tasks.stages`` by the counting fakes of tests/flows/fakes.py
    (flow tests under the Prefect test server, task tests through ``task.fn()``)."""
    from tasks import stages
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
