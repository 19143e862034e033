"""Projection of many world points into one frame and per-frame mask statistics for all instances at once.

Everything here is vectorised over instances: each mask frame is read once, and areas, bounding boxes
and point-in-mask counts of every instance come out of one ``bincount`` / ``find_objects`` pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from rescene_core.geometry.camera import project_to_pixels

__all__ = ["LabelTable", "project_to_pixels"]


@dataclass(frozen=True)
class LabelTable:
    """Maps capture instance ids to compact labels 1..N (0 = none / not tracked) for bincounts.

    ids: int64 [N] instance ids in compact order (compact label k + 1 is ids[k]).
    """

    ids: NDArray[np.int64]
    lut: NDArray[np.int32]

    @classmethod
    def build(cls, ids: NDArray | list[int]) -> LabelTable:
        ids = np.asarray(sorted({int(i) for i in ids if int(i) > 0}), dtype=np.int64)
        size = int(ids.max()) + 1 if len(ids) else 1
        lut = np.zeros(size, np.int32)
        lut[ids] = np.arange(1, len(ids) + 1, dtype=np.int32)
        return cls(ids, lut)

    @property
    def n(self) -> int:
        return len(self.ids)

    def compact(self, mask: NDArray) -> NDArray[np.int32]:
        """Compact labels [H, W] of a panoptic mask; ids outside the table become 0."""
        m = np.asarray(mask)
        inside = (m > 0) & (m < len(self.lut))
        return np.where(inside, self.lut[np.where(inside, m, 0)], 0).astype(np.int32)

    def index_of(self, instance_id: int) -> int:
        """Row (0-based) of an id, or -1."""
        if 0 < instance_id < len(self.lut):
            k = int(self.lut[instance_id])
            return k - 1
        return -1


def mask_stats(labels: NDArray[np.int32], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pixel areas [n] and bounding-box pixel counts [n] of compact labels 1..n in one frame."""
    area = np.bincount(labels.ravel(), minlength=n + 1)[1 : n + 1].astype(np.int64)
    bbox = np.zeros(n, np.int64)
    for k, sl in enumerate(ndimage.find_objects(labels, max_label=n)):
        if sl is not None:
            bbox[k] = (sl[0].stop - sl[0].start) * (sl[1].stop - sl[1].start)
    return area, bbox


def points_in_mask(
    labels: NDArray[np.int32],
    points_world: NDArray[np.float32],
    owner: NDArray[np.int32],
    K: NDArray[np.float64],
    world_from_cam: NDArray[np.float64],
    n: int,
) -> NDArray[np.int64]:
    """Per compact label 1..n, how many of its points [m, 3] (owner [m] in 1..n) project inside its mask."""
    h, w = labels.shape
    col, row, valid = project_to_pixels(points_world, K, world_from_cam, w, h)
    hit = valid & (labels[row, col] == owner)
    return np.bincount(owner[hit], minlength=n + 1)[1 : n + 1].astype(np.int64)
