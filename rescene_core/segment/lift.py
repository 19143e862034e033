"""2D masks lifted onto superpoints: each thinned point is projected into every frame (with a depth test
against the measured depth, so occluded points do not vote) and reads the frame's mask id there; a
superpoint's vote in a frame is the id most of its visible points read.

Used by ``--segment masks`` to merge superpoints into instances by view consensus (two touching
regions join when, in most frames that see both, one mask covers both: the idea of MaskClustering,
CVPR 2024, and SAI3D, restricted to touching superpoints; ``rescene_core.segment.masks``), and with
``majority_ids`` to give superpoints the synthetic truth's ids. Mask ids need not agree across frames: only equality within a frame is used.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.errors import SegmentError


@dataclass
class FrameVotes:
    """Per (superpoint, frame) seen: the frame's majority mask id over the superpoint's visible points.

    sp, frame, mask_id, share, seen: [m] each. share is the majority's fraction of the visible points,
    seen how many points of the superpoint were visible in the frame (inside the image, depth agreeing,
    the frame's mask present). Frames without a mask cast no votes."""

    sp: NDArray[np.int64]
    frame: NDArray[np.int64]
    mask_id: NDArray[np.int64]
    share: NDArray[np.float64]
    seen: NDArray[np.int64]


@dataclass
class FrameCounts:
    """Per (superpoint, frame, mask id) read by its visible points: how many points read it.

    sp, frame, mask_id, count: [m] each, sorted by (superpoint, frame). Frames without a mask read nothing."""

    sp: NDArray[np.int64]
    frame: NDArray[np.int64]
    mask_id: NDArray[np.int64]
    count: NDArray[np.int64]


def frame_counts(
    points: NDArray[np.float64],
    label: NDArray[np.int64],
    masks: Sequence[NDArray | None],
    K: NDArray,
    world_from_cam: NDArray,
    depth: NDArray[np.float32] | None,
    abs_tolerance: float = 0.05,
    rel_tolerance: float = 0.05,
) -> FrameCounts:
    """The mask ids the superpoints ``label`` [n] of ``points`` [n, 3] (world, m) read in each frame.

    masks: T id images [H, W] (0 = none) or None for a frame without one. K [T, 3, 3], world_from_cam
    [T, 4, 4] (OpenCV axes), depth [T, H, W] metres (0 invalid) or None (no occlusion test: a point
    farther than the measured depth by more than max(abs_tolerance, rel_tolerance * depth) is hidden). A
    pixel's centre is at (u + 0.5, v + 0.5), as in the project's renderer."""
    homog = np.c_[points, np.ones(len(points))]
    keys, counts_all = [], []
    for t, mask in enumerate(masks):
        if mask is None:
            continue
        H, W = mask.shape
        cam = (homog @ np.linalg.inv(np.asarray(world_from_cam[t], np.float64)).T)[:, :3]
        z = cam[:, 2]
        front = z > 1e-3
        k = np.asarray(K[t], np.float64)
        u = np.floor(k[0, 0] * cam[:, 0] / np.where(front, z, 1.0) + k[0, 2]).astype(np.int64)
        v = np.floor(k[1, 1] * cam[:, 1] / np.where(front, z, 1.0) + k[1, 2]).astype(np.int64)
        ok = front & (u >= 0) & (u < W) & (v >= 0) & (v < H)
        idx = np.flatnonzero(ok)
        if depth is not None:
            d = np.asarray(depth[t])[v[idx], u[idx]]
            agree = (d > 0) & (np.abs(d - z[idx]) <= np.maximum(abs_tolerance, rel_tolerance * d))
            idx = idx[agree]
        ids = np.asarray(mask)[v[idx], u[idx]].astype(np.int64)
        # one key per (superpoint, id) in this frame
        span = int(ids.max(initial=0)) + 1
        uk, cnt = np.unique(label[idx] * span + ids, return_counts=True)
        keys.append(np.stack([uk // span, np.full(len(uk), t), uk % span], 1))
        counts_all.append(cnt)
    if not keys:
        empty = np.zeros(0, np.int64)
        return FrameCounts(empty, empty, empty, empty)
    triples = np.concatenate(keys)
    counts = np.concatenate(counts_all)
    order = np.lexsort((-counts, triples[:, 1], triples[:, 0]))
    triples, counts = triples[order], counts[order]
    return FrameCounts(triples[:, 0], triples[:, 1], triples[:, 2], counts.astype(np.int64))


def votes_from_counts(counts: FrameCounts, n_frames: int, min_seen: int = 3) -> FrameVotes:
    """Each (superpoint, frame)'s majority id and its share (see ``FrameVotes``), from the ids its points
    read; superpoints with fewer than ``min_seen`` visible points in a frame cast no vote there."""
    if len(counts.sp) == 0:
        empty = np.zeros(0, np.int64)
        return FrameVotes(empty, empty, empty, np.zeros(0), empty)
    pair = counts.sp * n_frames + counts.frame
    first = np.r_[True, pair[1:] != pair[:-1]]
    seen = np.add.reduceat(counts.count, np.flatnonzero(first))
    keep = seen >= min_seen
    top = counts.count[first]
    return FrameVotes(
        counts.sp[first][keep],
        counts.frame[first][keep],
        counts.mask_id[first][keep],
        (top / np.maximum(seen, 1))[keep],
        seen[keep],
    )


def frame_votes(
    points: NDArray[np.float64],
    label: NDArray[np.int64],
    masks: Sequence[NDArray | None],
    K: NDArray,
    world_from_cam: NDArray,
    depth: NDArray[np.float32] | None,
    abs_tolerance: float = 0.05,
    rel_tolerance: float = 0.05,
    min_seen: int = 3,
) -> FrameVotes:
    """Votes of the superpoints ``label`` [n] of ``points`` [n, 3] (world, m) in each frame's mask (see
    ``frame_counts`` for the projection): the id most of a superpoint's visible points read. Superpoints
    with fewer than ``min_seen`` visible points in a frame cast no vote there."""
    counts = frame_counts(points, label, masks, K, world_from_cam, depth, abs_tolerance, rel_tolerance)
    return votes_from_counts(counts, len(masks), min_seen)


def majority_ids(votes: FrameVotes, n_sp: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Per superpoint: the id it takes in most frames (0 when never seen) and that id's share of its votes.
    Only meaningful when ids are consistent across frames (synthetic truth)."""
    key = votes.sp * (int(votes.mask_id.max(initial=0)) + 1) + votes.mask_id
    span = int(votes.mask_id.max(initial=0)) + 1
    uk, cnt = np.unique(key, return_counts=True)
    sp, ids = uk // span, uk % span
    order = np.lexsort((-cnt, sp))
    sp, ids, cnt = sp[order], ids[order], cnt[order]
    first = np.r_[True, sp[1:] != sp[:-1]] if len(sp) else np.zeros(0, bool)
    total = np.bincount(sp, cnt, n_sp)
    out = np.zeros(n_sp, np.int64)
    share = np.zeros(n_sp)
    out[sp[first]] = ids[first]
    share[sp[first]] = cnt[first] / np.maximum(total[sp[first]], 1)
    return out, share


def read_mask_dir(folder: str | Path, names: Sequence[str], height: int, width: int) -> list[NDArray | None]:
    """Per-frame id PNGs from ``folder``: ``<frame name>.png`` for each of ``names`` (a frame without one
    gets None: no votes). 8- or 16-bit single-channel PNGs hold ids directly; an RGB PNG's colours are
    ids (r * 65536 + g * 256 + b). Each must be ``height`` x ``width`` (the frames' size)."""
    from PIL import Image

    folder = Path(folder)
    if not folder.is_dir():
        raise SegmentError(f"{folder}: no such folder of per-frame mask PNGs (fix: pass --masks DIR)")
    by_stem = {p.stem: p for p in folder.iterdir() if p.suffix.lower() == ".png"}
    if not by_stem:
        raise SegmentError(
            f"{folder}: no PNG files; write one id image per frame named like the frame (e.g. 000012.png)"
        )
    out: list[NDArray | None] = []
    for name in names:
        path = by_stem.get(name)
        if path is None:
            out.append(None)
            continue
        try:
            img = np.asarray(Image.open(path))
        except OSError as err:
            raise SegmentError(f"{path}: not a readable PNG ({err}); write an id image per frame") from err
        if img.ndim == 3:
            rgb = img[..., :3].astype(np.int64)
            img = (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
        if img.shape != (height, width):
            raise SegmentError(
                f"{path}: a {img.shape[1]} x {img.shape[0]} mask for {width} x {height} frames; write the masks at "
                "the frames' resolution"
            )
        out.append(img.astype(np.int64))
    if all(m is None for m in out):
        raise SegmentError(
            f"{folder}: none of the {len(by_stem)} PNGs is named like a frame (frames: {', '.join(names[:3])}, ...); "
            "name each mask after its frame's image"
        )
    return out
