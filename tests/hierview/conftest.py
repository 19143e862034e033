"""The rendered test room, written once per test session."""

from __future__ import annotations

import pytest

from rescene_core.capture import open_capture
from tests.hierview.room import make_room, write_room


@pytest.fixture(scope="session")
def room():
    return make_room()


@pytest.fixture(scope="session")
def room_capture(room, tmp_path_factory):
    return open_capture(write_room(tmp_path_factory.mktemp("room") / "room.zarr", room))
