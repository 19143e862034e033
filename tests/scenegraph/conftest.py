from __future__ import annotations

import pytest

from rescene_core.capture import open_capture, write_capture
from tests.scenegraph.room import room_arrays, room_shell


@pytest.fixture(scope="session")
def room_capture(tmp_path_factory):
    path = tmp_path_factory.mktemp("room") / "room.zarr"
    write_capture(path, room_arrays())
    return open_capture(path)


@pytest.fixture(scope="session")
def shell():
    return room_shell()
