"""``--segment masks``: instances from any 2D segmenter's per-frame masks, merged in 3D by view consensus.

The scan is fused and over-segmented as in the geometric front end (``rescene_core.segment.geometric``:
TSDF, structure planes, superpoints). Each superpoint reads its id in every frame's mask
(``rescene_core.segment.lift``); two touching superpoints join when, among the frames in which both
cast a confident vote, most give them the same id. Ids need not agree across frames, so SAM 2 automatic
masks or CropFormer's can be used as they are written. A superpoint most frames leave unmasked (id 0), or
that no frame sees, belongs to no instance. Regions are then filtered as in the geometric front end; a
consensus region lying on a wall and hanging clear of the floor and ceiling is a flush object (a picture,
a mirror, a TV), one that reaches the floor (a door) or spans the wall stays wall.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric import (
    ScanPoints,
    SegmentConfig,
    SegmentResult,
    _absorb_small,
    _components,
    _filter_regions,
    _finish,
    fuse_scan,
    wall_superpoints,
)
from rescene_core.segment.lift import FrameVotes, frame_votes, pair_agreement


def vote_sample(sp: ScanPoints, per_superpoint: int, seed: int = 0) -> NDArray[np.int64]:
    """Indices of at most ``per_superpoint`` points of each superpoint (all of the smaller ones), chosen
    at random with ``seed``: enough to read a superpoint's id in a frame, at a fraction of the cost."""
    rng = np.random.default_rng(seed)
    label = sp.graph.label
    order = np.lexsort((rng.random(len(label)), label))
    first = np.searchsorted(label[order], np.arange(sp.graph.size))
    rank = np.arange(len(label)) - np.repeat(first, sp.graph.count)
    return np.sort(order[rank < per_superpoint])


def consensus_regions(
    sp: ScanPoints, votes: FrameVotes, n_frames: int, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], dict[str, int]]:
    """Region [s] of each superpoint (0: none) by view consensus, and counts for the report."""
    g = sp.graph
    n = g.size
    both, same = pair_agreement(votes, g.pairs, n_frames, cfg.vote_min_share)
    join = (both >= cfg.consensus_min_frames) & (same >= cfg.consensus_fraction * np.maximum(both, 1))
    join &= g.contacts >= cfg.min_contacts
    voted = np.bincount(votes.sp, minlength=n)
    unmasked = np.bincount(votes.sp, (votes.mask_id == 0).astype(float), n)
    masked = (voted > 0) & (unmasked < 0.5 * np.maximum(voted, 1))
    comp = _components(n, g.pairs, join & masked[g.pairs[:, 0]] & masked[g.pairs[:, 1]])
    region = np.where(masked, comp + 1, 0)
    stats = {
        "superpoints": int(n),
        "contacts": int(len(g.pairs)),
        "joined_by_consensus": int(join.sum()),
        "unseen_superpoints": int((voted == 0).sum()),
        "unmasked_superpoints": int(((voted > 0) & ~masked).sum()),
    }
    return region, stats


def segment_masks(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    frame_masks: Sequence[NDArray | None],
    config: SegmentConfig | None = None,
    clip_model: str | None = None,
    clip_model_name: str = "ViT-B-32",
    vocabulary: tuple[str, ...] = ("object",),
) -> SegmentResult:
    """Instances of an aligned RGB-D capture (world z up, floor at z = 0) from per-frame 2D masks.

    rgb [T, H, W, 3] uint8, depth [T, H, W] float32 metres (0 invalid), K [T, 3, 3], world_from_cam
    [T, 4, 4] (OpenCV axes). frame_masks: T id images [H, W] (0 = no mask; ids need not agree across
    frames) or None for a frame without one. clip_model: a local open_clip checkpoint to label segments.
    """
    cfg = config or SegmentConfig()
    T, H, W = depth.shape
    if len(frame_masks) != T:
        raise SegmentError(f"{len(frame_masks)} masks for {T} frames; give one mask (or None) per frame")
    shapes = {m.shape for m in frame_masks if m is not None}
    if not shapes:
        raise SegmentError("no frame has a mask; --segment masks needs per-frame id images")
    if shapes != {(H, W)}:
        raise SegmentError(f"masks of sizes {sorted(shapes)} for {W} x {H} frames; write them at the frames' size")
    verts, faces, struct, planes, sp, seconds = fuse_scan(rgb, depth, K, world_from_cam, cfg, cfg.masks_fh_k)
    t = time.perf_counter()
    pick = vote_sample(sp, cfg.vote_points, cfg.seed)
    votes = frame_votes(
        sp.points[pick], sp.graph.label[pick], frame_masks, K, world_from_cam, depth,
        cfg.depth_abs_tolerance, cfg.depth_rel_tolerance, cfg.vote_min_points,
    )  # fmt: skip
    seconds["votes"] = time.perf_counter() - t
    t = time.perf_counter()
    region, stats = consensus_regions(sp, votes, T, cfg)
    which, _ = wall_superpoints(sp, planes, cfg)
    # consensus regions are no fragments of geometry: they keep the smaller least size
    small = cfg.model_copy(update={"min_segment_points": cfg.masks_min_segment_points})
    region = _absorb_small(sp.graph, region, small)
    region, drop = _filter_regions(sp, region, which, planes, small, flush_by_masks=True)
    stats |= drop
    stats["frames_with_masks"] = sum(m is not None for m in frame_masks)
    seconds["merge"] = time.perf_counter() - t
    t = time.perf_counter()
    result = _finish(rgb, depth, K, world_from_cam, verts, faces, struct, planes, sp, region, cfg, "masks",
                     stats, clip_model, clip_model_name, vocabulary)  # fmt: skip
    seconds["render_and_labels"] = time.perf_counter() - t
    result.report["seconds"] = {k: round(v, 2) for k, v in seconds.items()}
    return result
