"""A wall-labelled face standing in front of the wall behind it (wall cabinets whose masks say "wall") is not
the room's boundary; walls side by side (an L-shaped room's notch) are both kept."""

from __future__ import annotations

import numpy as np

from rescene_core.capture import open_capture, write_capture
from rescene_core.config import ShellConfig
from rescene_core.shell import estimate_shell
from tests.fixtures import Box, box_capture_arrays, look_at, pinhole

THIN = 0.002
CAMERAS = [(1.5, 2.6, 1.6), (2.2, 2.8, 1.7), (2.9, 2.6, 1.6)]


def _shell(tmp_path, boxes, config=None):
    poses = np.asarray([look_at(np.array(c), np.array([2.0, 0.4, 1.0])) for c in CAMERAS])
    arrays = box_capture_arrays(boxes, poses, pinhole(64, 48, 45.0), 64, 48, point_density=4000.0, scene_id="w")
    return estimate_shell(open_capture(write_capture(tmp_path / "w.zarr", arrays), validate=False), config)


def _offsets(shell, normal):
    return sorted(round(w.plane.offset, 2) for w in shell.walls if np.dot(w.plane.normal[:2], normal) > 0.98)


def test_a_face_in_front_of_its_wall_is_dropped(tmp_path):
    boxes = [
        Box(1, "floor", (0.0, 0.0, -THIN), (4.0, 3.0, 0.0), (150, 130, 110), True),
        Box(2, "wall", (0.0, -THIN, 0.0), (4.0, 0.0, 2.5), (225, 225, 215), True),  # the wall, y = 0
        Box(3, "wall", (0.5, 0.35, 1.45), (3.5, 0.35 + THIN, 2.2), (225, 225, 215), True),  # cabinet fronts
        Box(4, "wall", (-THIN, 0.0, 0.0), (0.0, 3.0, 2.5), (225, 225, 215), True),  # x = 0
    ]
    kept = _shell(tmp_path / "a", boxes)
    assert _offsets(kept, (0.0, 1.0)) == [0.0]  # only the wall behind, not the fronts at y = 0.35
    assert len(kept.walls) == 2
    assert min(y for _, y in kept.floor_polygon) < 0.05  # the floor reaches the wall under the cabinets
    every = _shell(tmp_path / "b", boxes, ShellConfig(wall_shadow_overlap=1e9))  # the rule off: three walls
    assert _offsets(every, (0.0, 1.0)) == [-0.35, 0.0]


def test_walls_side_by_side_are_both_kept(tmp_path):
    boxes = [
        Box(1, "floor", (0.0, 0.0, -THIN), (4.0, 3.0, 0.0), (150, 130, 110), True),
        Box(2, "wall", (0.0, -THIN, 0.0), (2.0, 0.0, 2.5), (225, 225, 215), True),  # y = 0 for x in [0, 2]
        Box(3, "wall", (2.0, 0.6, 0.0), (4.0, 0.6 + THIN, 2.5), (225, 225, 215), True),  # y = 0.6 for x in [2, 4]
        Box(4, "wall", (2.0 - THIN, 0.0, 0.0), (2.0, 0.6, 2.5), (225, 225, 215), True),  # the notch's side
    ]
    shell = _shell(tmp_path, boxes)
    assert _offsets(shell, (0.0, 1.0)) == [-0.6, 0.0]
