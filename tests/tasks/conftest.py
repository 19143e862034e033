"""Task tests call each task's function through ``task.fn()``: no Prefect server, stage libraries
replaced by the counting doubles of tests/flows/fakes.py."""

from __future__ import annotations

import pytest


@pytest.fixture
def fake_stages(monkeypatch):
    from tasks import stages
    from tests.flows import fakes

    for name, fn in fakes.STAGE_FAKES.items():
        monkeypatch.setattr(stages, name, fn)
    fakes.CALLS.clear()
    return fakes.CALLS


@pytest.fixture(scope="session")
def box_capture_path(tmp_path_factory):
    from tests.flows.fakes import box_capture

    return box_capture(tmp_path_factory.mktemp("capture") / "boxes.zarr")


@pytest.fixture
def capture(box_capture_path):
    from tasks.common import capture_ref

    return capture_ref(box_capture_path)
