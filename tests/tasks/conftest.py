"""Task tests call each task's function through ``task.fn()``: no Prefect server, stage libraries
replaced by the counting doubles of tests/flows/fakes.py (the ``fake_stages`` and ``box_capture_path``
fixtures live in tests/conftest.py, shared with the flow tests)."""

from __future__ import annotations

import pytest


@pytest.fixture
def capture(box_capture_path):
    from rescene_core.stages.execution import capture_ref

    return capture_ref(box_capture_path)
