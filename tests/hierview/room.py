"""A small ray-cast room (floor, walls, coloured boxes) written as a capture, for the HierView and shell tests.

Cameras stand inside a 4 x 3 m room looking outwards and down; the test fixture builder (``tests/fixtures.py``)
renders masks, depth and colours, and instance point clouds are sampled on the boxes, so masks and points agree
exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rescene_core.capture import CaptureArrays, write_capture
from rescene_core.render import Light
from tests.fixtures import Box, box_capture_arrays, look_at, pinhole

ROOM = (4.0, 3.0, 2.5)
THIN = 0.002
"""Thickness of the floor and wall slabs (m): thin, so each is one surface for plane fitting."""

OBJECTS = [
    # id, label, centre (x, y), size (sx, sy, sz), colour
    (10, "cabinet", (0.5, 0.4), (0.6, 0.5, 1.2), (200, 40, 40)),
    (11, "table", (2.0, 1.5), (1.0, 0.6, 0.7), (40, 160, 40)),
    (12, "sofa", (3.3, 2.4), (1.0, 0.8, 0.8), (40, 60, 200)),
    (13, "chair", (2.9, 0.5), (0.5, 0.5, 0.9), (220, 200, 40)),
    (14, "box", (0.6, 2.5), (0.5, 0.5, 0.5), (180, 60, 200)),
    (15, "lamp", (1.2, 1.3), (0.3, 0.3, 1.5), (40, 200, 200)),
]

OVERVIEWS = [(0.4, 0.3, 2.2), (3.6, 2.7, 2.2), (3.6, 0.3, 2.2)]
"""Camera centres of the overview frames (corners, looking at the room centre)."""

LIGHT = Light((2.0, 1.5, 2.4), intensity=0.5, falloff=0.0)
"""One ceiling light over the room centre: faces differ in brightness by their orientation."""


@dataclass
class Room:
    arrays: CaptureArrays
    boxes: dict[int, Box] = field(default_factory=dict)
    labels: dict[int, str] = field(default_factory=dict)


def make_room(
    frames: int = 16,
    width: int = 96,
    height: int = 72,
    open_side: bool = False,
    structural: bool = True,
    closeups: int = 2,
    overviews: int = 2,
    seed: int = 0,
    point_density: float = 600.0,
) -> Room:
    """Render the room. Frames: ``frames`` ring views, ``overviews`` corner views of the room centre, then
    ``closeups`` close-ups that truncate the table (id 11)."""
    sx, sy, sz = ROOM
    walls = {
        2: ((-THIN, 0, 0), (0, sy, sz)),
        3: ((sx, 0, 0), (sx + THIN, sy, sz)),
        4: ((0, -THIN, 0), (sx, 0, sz)),
        5: ((0, sy, 0), (sx, sy + THIN, sz)),
    }
    if open_side:
        walls.pop(5)
    boxes = {1: Box(1, "floor", (0, 0, -THIN), (sx, sy, 0), (150, 130, 110), structural)}
    for wid, (lo, hi) in walls.items():
        boxes[wid] = Box(wid, "wall", lo, hi, (225, 225, 215), structural)
    for oid, label, (cx, cy), (ox, oy, oz), colour in OBJECTS:
        boxes[oid] = Box(oid, label, (cx - ox / 2, cy - oy / 2, 0), (cx + ox / 2, cy + oy / 2, oz), colour)

    centre = np.array([sx / 2, sy / 2])
    poses = []
    for t in range(frames):
        a = 2 * np.pi * t / frames
        d = np.array([np.cos(a), np.sin(a)])
        poses.append(look_at(np.array([*(centre - 0.8 * d), 1.6]), np.array([*(centre + 1.6 * d), 0.4])))
    for eye in OVERVIEWS[:overviews]:
        poses.append(look_at(np.array(eye), np.array([2.0, 1.5, 0.3])))
    for c in range(closeups):
        poses.append(look_at(np.array([1.8 + 0.2 * c, 0.95, 1.0]), np.array([1.8 + 0.2 * c, 1.5, 0.55])))
    arrays = box_capture_arrays(
        list(boxes.values()),
        np.asarray(poses),
        pinhole(width, height, 0.8 * width),
        width,
        height,
        points="surface",
        point_density=point_density,
        rgb_noise=4.0,
        lights=(LIGHT,),
        ambient=0.6,
        seed=seed,
        scene_id="room",
    )
    return Room(arrays, boxes, {i: b.label for i, b in boxes.items()})


def write_room(path: Path, room: Room) -> Path:
    return write_capture(path, room.arrays)
