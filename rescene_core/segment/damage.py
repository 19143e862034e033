"""Per-frame class-agnostic masks made from synthetic truth, damaged the way a 2D segmenter's are, to test
``--segment masks`` without a segmenter: ids drawn at random in every frame (no identity across frames, as
SAM 2's automatic masks or CropFormer write them), objects split in two (over-segmentation), touching
objects given one id (under-segmentation), outlines eroded or dilated by a few pixels, and frames with no
mask at all.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict
from scipy import ndimage


class MaskDamage(BaseModel):
    """How badly the truth is damaged. Probabilities are per object and frame unless said otherwise."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    split: float = 0.15
    """An object's mask cut in two along a random line through its centre (over-segmentation)."""
    merge: float = 0.15
    """An object's mask given the id of a neighbour it touches in the image (under-segmentation)."""
    boundary_px: int = 3
    """Outlines are eroded or dilated by up to this many pixels (each object and frame at random)."""
    missing_frames: float = 0.15
    """Share of frames without a mask file (the segmenter skipped or failed them)."""
    drop: float = 0.05
    """An object missing from a frame's mask (the segmenter did not propose it)."""


def damage_masks(
    truth: NDArray[np.integer], rng: np.random.Generator, damage: MaskDamage | None = None
) -> list[NDArray[np.int32] | None]:
    """Damaged copies of ``truth`` [T, H, W] (ids consistent across frames, 0 = none): one id image per
    frame with ids drawn at random in that frame, or None for a missing frame (see ``MaskDamage``)."""
    dmg = damage or MaskDamage()
    out: list[NDArray[np.int32] | None] = []
    T = len(truth)
    missing = set(rng.choice(T, size=int(round(dmg.missing_frames * T)), replace=False).tolist())
    for t in range(T):
        if t in missing:
            out.append(None)
            continue
        frame = np.asarray(truth[t]).astype(np.int64)
        ids = [int(i) for i in np.unique(frame) if i > 0]
        work = frame.copy()
        nxt = int(frame.max(initial=0)) + 1
        for i in ids:
            sel = frame == i
            if rng.random() < dmg.drop:
                work[sel] = 0
                continue
            if rng.random() < dmg.split and sel.sum() > 50:
                v, u = np.nonzero(sel)
                angle = rng.uniform(0, np.pi)
                side = (u - u.mean()) * np.cos(angle) + (v - v.mean()) * np.sin(angle) > 0
                work[v[side], u[side]] = nxt
                nxt += 1
            if rng.random() < dmg.merge:
                ring = ndimage.binary_dilation(sel, iterations=3) & ~sel
                touching = [int(j) for j in np.unique(frame[ring]) if j > 0 and j != i]
                if touching:
                    other = touching[int(rng.integers(len(touching)))]
                    work[work == other] = i
        for i in [int(k) for k in np.unique(work) if k > 0]:
            r = int(rng.integers(-dmg.boundary_px, dmg.boundary_px + 1))
            if r == 0:
                continue
            sel = work == i
            if r < 0:
                work[sel & ~ndimage.binary_erosion(sel, iterations=-r)] = 0
            else:
                work[ndimage.binary_dilation(sel, iterations=r) & (work != i)] = i
        present = np.unique(work[work > 0])
        perm = np.zeros(int(work.max(initial=0)) + 1, np.int64)
        perm[present] = rng.permutation(np.arange(1, len(present) + 1)) + int(rng.integers(0, 1000))
        out.append(perm[work].astype(np.int32))
    return out
