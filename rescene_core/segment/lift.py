"""2D masks lifted onto superpoints: each thinned point is projected into every frame (with a depth test
against the measured depth, so occluded points do not vote) and reads the frame's mask id there; a
superpoint's vote in a frame is the id most of its visible points read.

Used twice: by ``--segment masks`` to merge superpoints into instances by view consensus (two touching
superpoints join when, in most frames that see both, one mask covers both: the idea of MaskClustering,
CVPR 2024, and SAI3D, restricted to touching superpoints), and by the benchmark to give superpoints the
synthetic truth's ids. Mask ids need not agree across frames: only equality within a frame is used.
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
    """Votes of the superpoints ``label`` [n] of ``points`` [n, 3] (world, m) in each frame's mask.

    masks: T id images [H, W] (0 = none) or None for a frame without one. K [T, 3, 3], world_from_cam
    [T, 4, 4] (OpenCV axes), depth [T, H, W] metres (0 invalid) or None (no occlusion test). A pixel's
    centre is at (u + 0.5, v + 0.5), as in the project's renderer. Superpoints with fewer than
    ``min_seen`` visible points in a frame cast no vote there."""
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
        key = label[idx] * (int(ids.max(initial=0)) + 1) + ids
        uk, cnt = np.unique(key, return_counts=True)
        span = int(ids.max(initial=0)) + 1
        keys.append(np.stack([uk // span, np.full(len(uk), t), uk % span], 1))
        counts_all.append(cnt)
    if not keys:
        empty = np.zeros(0, np.int64)
        return FrameVotes(empty, empty, empty, np.zeros(0), empty)
    triples = np.concatenate(keys)
    counts = np.concatenate(counts_all)
    pair = triples[:, 0] * len(masks) + triples[:, 1]
    order = np.lexsort((-counts, pair))
    pair, triples, counts = pair[order], triples[order], counts[order]
    first = np.r_[True, pair[1:] != pair[:-1]]
    seen = np.add.reduceat(counts, np.flatnonzero(first))
    best = triples[first]
    keep = seen >= min_seen
    return FrameVotes(
        best[keep, 0], best[keep, 1], best[keep, 2], (counts[first] / np.maximum(seen, 1))[keep], seen[keep]
    )


def pair_agreement(
    votes: FrameVotes, pairs: NDArray[np.int64], n_frames: int, min_share: float = 0.5
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For each superpoint pair [p, 2]: frames where both cast a confident vote (majority share >=
    ``min_share``, id not 0), and how many of those gave both the same id. Returns (both [p], same [p])."""
    conf = (votes.share >= min_share) & (votes.mask_id > 0)
    table: dict[int, int] = dict(
        zip((votes.sp[conf] * n_frames + votes.frame[conf]).tolist(), votes.mask_id[conf].tolist(), strict=True)
    )
    both = np.zeros(len(pairs), np.int64)
    same = np.zeros(len(pairs), np.int64)
    by_sp: dict[int, list[int]] = {}
    for s, t in zip(votes.sp[conf].tolist(), votes.frame[conf].tolist(), strict=True):
        by_sp.setdefault(s, []).append(t)
    for p, (a, b) in enumerate(pairs.tolist()):
        fa = by_sp.get(a)
        fb = by_sp.get(b)
        if not fa or not fb:
            continue
        common = set(fa).intersection(fb)
        both[p] = len(common)
        same[p] = sum(table[a * n_frames + t] == table[b * n_frames + t] for t in common)
    return both, same


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
