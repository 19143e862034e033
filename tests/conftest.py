"""Shared fixtures. Prefect runs against a throwaway home so tests never touch a user's profile."""

from __future__ import annotations

import os
import tempfile

import pytest

os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_HOME", tempfile.mkdtemp(prefix="rescene-prefect-home-"))


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
