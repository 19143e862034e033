"""A small hand-built room for the scene-graph tests: floor, four walls, a table with a lamp on it,
a chair, a cabinet against a wall and a picture on a wall, rendered from a ring of cameras.

The test fixture builder (``tests/fixtures.py``) renders masks, depth and colours; each instance's point
cloud is its rendered surface over all frames (what the capture saw). The room shell is built by hand from
the known planes.
"""

from __future__ import annotations

import numpy as np

from rescene_core.capture import CaptureArrays
from rescene_core.records import InstanceId, Plane, Relation, RoomShell, Root, WallPlane
from tests.fixtures import Box, box_capture_arrays, look_at, pinhole

SIZE = 4.0
WIDTH, HEIGHT = 160, 120
FOCAL = 110.0

# id: (label, structural, box extents (x, y, z), box centre)
BOXES = {
    1: ("floor", True, (SIZE, SIZE, 0.02), (SIZE / 2, SIZE / 2, -0.01)),
    2: ("wall", True, (0.02, SIZE, 2.6), (-0.01, SIZE / 2, 1.3)),
    3: ("wall", True, (0.02, SIZE, 2.6), (SIZE + 0.01, SIZE / 2, 1.3)),
    4: ("wall", True, (SIZE, 0.02, 2.6), (SIZE / 2, -0.01, 1.3)),
    5: ("wall", True, (SIZE, 0.02, 2.6), (SIZE / 2, SIZE + 0.01, 1.3)),
    6: ("table", False, (1.0, 0.6, 0.75), (2.2, 2.3, 0.375)),
    7: ("table lamp", False, (0.2, 0.2, 0.4), (2.4, 2.35, 0.95)),
    8: ("picture", False, (0.7, 0.03, 0.45), (2.0, SIZE - 0.015, 1.6)),
    9: ("chair", False, (0.45, 0.45, 0.9), (1.3, 2.2, 0.45)),
    10: ("cabinet", False, (0.5, 1.0, 1.2), (0.25, 1.2, 0.6)),
}
GT = {
    6: (Relation.RESTS_ON, Root.FLOOR),
    7: (Relation.RESTS_ON, InstanceId(6)),
    8: (Relation.MOUNTS_ON, Root.WALL),
    9: (Relation.RESTS_ON, Root.FLOOR),
    10: (Relation.RESTS_ON, Root.FLOOR),
}


def room_shell() -> RoomShell:
    walls = (
        WallPlane(0, Plane((1.0, 0.0, 0.0), 0.0), ((0.0, 0.0), (0.0, SIZE))),
        WallPlane(1, Plane((-1.0, 0.0, 0.0), SIZE), ((SIZE, 0.0), (SIZE, SIZE))),
        WallPlane(2, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (SIZE, 0.0))),
        WallPlane(3, Plane((0.0, -1.0, 0.0), SIZE), ((0.0, SIZE), (SIZE, SIZE))),
    )
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), walls, ((0.0, 0.0), (SIZE, 0.0), (SIZE, SIZE), (0.0, SIZE)), 2.6)


def room_arrays(frames: int = 8, seed: int = 0, boxes: dict | None = None) -> CaptureArrays:
    """Render ``boxes`` (default BOXES: id -> (label, structural, extents, centre)) from a ring of cameras;
    each instance's points are its rendered surface over all frames."""
    boxes = BOXES if boxes is None else boxes
    rng = np.random.default_rng(seed)
    placed = [
        Box.centred(iid, label, centre, extents, rng.integers(40, 230, 3), structural)
        for iid, (label, structural, extents, centre) in boxes.items()
    ]
    poses = []
    for k in range(frames):
        angle = 2 * np.pi * k / frames + 0.3
        eye = np.array([SIZE / 2 + 1.5 * np.cos(angle), SIZE / 2 + 1.5 * np.sin(angle), 1.6])
        target = np.array([SIZE / 2 - 0.6 * np.cos(angle), SIZE / 2 - 0.6 * np.sin(angle), 0.7])
        poses.append(look_at(eye, target))
    return box_capture_arrays(
        placed, np.asarray(poses), pinhole(WIDTH, HEIGHT, FOCAL), WIDTH, HEIGHT, points="depth", scene_id="test-room"
    )
