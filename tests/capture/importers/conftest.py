"""A tiny synthetic scene shared by the importer tests (rendered once per session)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rescene_core.capture.synth import make_scene

HOLOLENS = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "hololens-000"
"""The real RGB-D sample, relative to the repository (../shared/data/hololens-000)."""


@pytest.fixture(scope="session")
def tiny_scene():
    return make_scene("tiny", seed=0)


@pytest.fixture(scope="session")
def hololens() -> Path:
    if not (HOLOLENS / "poses.txt").is_file():
        pytest.skip(f"the real RGB-D sample is not at {HOLOLENS.resolve()} (it lives in shared/data/)")
    return HOLOLENS.resolve()
