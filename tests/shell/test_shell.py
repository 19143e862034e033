"""Room shell from labelled structure, from raw points, with an open side, clutter and noise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from shapely.geometry import Polygon, box

from rescene_core.capture import open_capture, write_capture
from rescene_core.config import ShellConfig
from rescene_core.records import RoomShell
from rescene_core.shell import ShellError, estimate_shell, load_shell, plot_shell, save_shell
from tests.hierview.room import ROOM, make_room

ROOM_BOX = box(0, 0, ROOM[0], ROOM[1])


def _capture(tmp_path, name, **kw):
    room = make_room(frames=8, closeups=0, **kw)
    return room, open_capture(write_capture(tmp_path / f"{name}.zarr", room.arrays), validate=False)


def _check(shell: RoomShell, walls: int, iou_min: float = 0.97) -> None:
    assert shell.floor.normal == (0.0, 0.0, 1.0) and abs(shell.floor.offset) < 0.01
    poly = Polygon(shell.floor_polygon)
    assert poly.is_valid and poly.exterior.is_ccw
    iou = poly.intersection(ROOM_BOX).area / poly.union(ROOM_BOX).area
    assert iou >= iou_min
    assert len(shell.walls) == walls
    for w in shell.walls:
        n = np.asarray(w.plane.normal)
        assert n[2] == 0 and np.isclose(np.linalg.norm(n), 1)
        assert w.plane.signed_distance(np.array([[ROOM[0] / 2, ROOM[1] / 2, 1.0]]))[0] > 0  # points into the room
        # each wall is one of the room's sides
        assert min(abs(w.plane.offset), abs(w.plane.offset - ROOM[0]), abs(w.plane.offset - ROOM[1])) < 0.02


@pytest.mark.parametrize("structural", [True, False])
@pytest.mark.parametrize("open_side", [False, True])
def test_shell(tmp_path, structural, open_side):
    _, cap = _capture(tmp_path, "room", structural=structural, open_side=open_side)
    shell = estimate_shell(cap, ShellConfig())
    _check(shell, 3 if open_side else 4)


def test_shell_with_noise_and_clutter(tmp_path):
    room, _ = _capture(tmp_path, "clean", structural=False)
    rng = np.random.default_rng(3)
    a = room.arrays
    pts = a.points + rng.normal(0, 0.01, a.points.shape).astype(np.float32)
    pts[rng.choice(len(pts), len(pts) // 50, replace=False)] += rng.normal(0, 0.5, (len(pts) // 50, 3)).astype(
        np.float32
    )  # 2 % outliers
    cap = open_capture(write_capture(tmp_path / "noisy.zarr", dataclasses.replace(a, points=pts)), validate=False)
    _check(estimate_shell(cap, ShellConfig()), 4, iou_min=0.95)


def test_save_load_and_plot(tmp_path):
    _, cap = _capture(tmp_path, "room")
    shell = estimate_shell(cap)
    path = save_shell(tmp_path / "shell.json", shell)
    assert load_shell(path) == shell
    png = plot_shell(tmp_path / "shell.png", shell, cap)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000


def test_no_points_is_a_clear_error(tmp_path):
    room, _ = _capture(tmp_path, "room")
    a = room.arrays
    empty = dataclasses.replace(
        a,
        point_ids=a.point_ids,
        point_offsets=np.zeros_like(a.point_offsets),
        points=np.zeros((0, 3), np.float32),
        colors=np.zeros((0, 3), np.uint8),
    )
    cap = open_capture(write_capture(tmp_path / "empty.zarr", empty), validate=False)
    with pytest.raises(ShellError, match="finite instance points"):
        estimate_shell(cap)
