"""A two-frame capture of two boxes: enough to exercise the format and the validator.

Camera 0 sits at the origin and camera t at x = 0.1 t, all looking along world +z (OpenCV axes) at a
"chair" box (id 2) in front of a "floor" slab (id 1, structural) that fills the view; rendered by the test
fixture builder (``tests/fixtures.py``), so masks, depth and points agree.
"""

from __future__ import annotations

import numpy as np

from rescene_core.capture import CaptureArrays
from tests.fixtures import Box, box_capture_arrays, pinhole


def toy_capture_arrays(frames: int = 2, width: int = 32, height: int = 24) -> CaptureArrays:
    poses = np.tile(np.eye(4), (frames, 1, 1))
    poses[:, 0, 3] = np.arange(frames) * 0.1
    boxes = [
        Box(1, "floor", (-3.0, -3.0, 3.0), (3.0, 3.0, 3.05), (150, 130, 110), structural=True),
        Box.centred(2, "chair", (0.05, -0.1, 2.0), (0.6, 0.5, 0.3), (200, 40, 40)),
    ]
    return box_capture_arrays(
        boxes, poses, pinhole(width, height, 30.0), width, height, point_density=40.0, rgb_noise=6.0, scene_id="toy"
    )
