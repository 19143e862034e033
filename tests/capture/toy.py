"""A hand-made two-frame capture: enough to exercise the format and the validator."""

from __future__ import annotations

import numpy as np

from rescene_core.capture import CaptureArrays, points_to_csr
from rescene_core.records import Instance, InstanceId


def toy_capture_arrays(frames: int = 2, width: int = 32, height: int = 24) -> CaptureArrays:
    rng = np.random.default_rng(0)
    K = np.tile(np.array([[30.0, 0, width / 2], [0, 30.0, height / 2], [0, 0, 1]]), (frames, 1, 1))
    poses = np.tile(np.eye(4), (frames, 1, 1))
    poses[:, 0, 3] = np.arange(frames) * 0.1
    masks = np.zeros((frames, height, width), np.int32)
    masks[:, 5:15, 5:15] = 2
    masks[:, 18:, :] = 1
    clouds = {
        1: (rng.normal(size=(50, 3)).astype(np.float32), rng.integers(0, 255, (50, 3), dtype=np.uint8)),
        2: (rng.normal(size=(80, 3)).astype(np.float32), rng.integers(0, 255, (80, 3), dtype=np.uint8)),
    }
    ids, offsets, pts, cols = points_to_csr(clouds)
    return CaptureArrays(
        scene_id="toy",
        rgb=rng.integers(0, 255, (frames, height, width, 3), dtype=np.uint8),
        K=K,
        world_from_cam=poses,
        instance_masks=masks,
        instances=(Instance(InstanceId(1), "floor", True), Instance(InstanceId(2), "chair")),
        point_ids=ids,
        point_offsets=offsets,
        points=pts,
        colors=cols,
        depth=np.full((frames, height, width), 2.0, np.float32),
        source="toy",
    )
