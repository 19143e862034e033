"""``--segment masks``: instances from any 2D segmenter's per-frame masks, merged in 3D by view consensus.

The scan is fused and over-segmented as in the geometric front end (``rescene_core.segment.geometric``:
TSDF, structure planes, superpoints). Each superpoint reads its id in every frame's mask
(``rescene_core.segment.lift``); touching regions, starting from the superpoints, are merged
agglomeratively, the best agreeing pair first, while among the frames in which both cast a confident vote
most give them the same id. A region votes with all its points, so a superpoint straddling two objects
cannot bridge them; the points of such a superpoint that read a touching region's id in most frames are
then split off to that region (``split_straddling``). Regions parted by a gap of unmasked surface (a lamp's
shade and base, its thin pole left unmasked by eroded outlines) join when nearly every frame that sees both
gives them one id (``bridge_gaps``). Ids need not agree across frames, so SAM 2 automatic
masks or CropFormer's can be used as they are written. A superpoint most frames leave unmasked (id 0), or
that no frame sees, belongs to no instance. Regions are then filtered as in the geometric front end; a
consensus region lying on a wall and hanging clear of the floor and ceiling is a flush object (a picture,
a mirror, a TV), one that reaches the floor (a door) or spans the wall stays wall.
"""

from __future__ import annotations

import heapq
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric import (
    ScanPoints,
    SegmentConfig,
    SegmentResult,
    fuse_scan,
    points_by_region,
    regroup,
    wall_superpoints,
)
from rescene_core.segment.geometric.filter import _filter_regions
from rescene_core.segment.geometric.joins import _absorb_small
from rescene_core.segment.geometric.result import _finish
from rescene_core.segment.lift import FrameCounts, frame_counts, votes_from_counts


def vote_sample(sp: ScanPoints, per_superpoint: int, seed: int = 0) -> NDArray[np.int64]:
    """Indices of at most ``per_superpoint`` points of each superpoint (all of the smaller ones), chosen
    at random with ``seed``: enough to read a superpoint's id in a frame, at a fraction of the cost."""
    rng = np.random.default_rng(seed)
    label = sp.graph.label
    order = np.lexsort((rng.random(len(label)), label))
    first = np.searchsorted(label[order], np.arange(sp.graph.size))
    rank = np.arange(len(label)) - np.repeat(first, sp.graph.count)
    return np.sort(order[rank < per_superpoint])


class _RegionVotes:
    """The mask ids a growing region's points read, frame by frame: {frame: {id: points}}, and its
    confident vote per frame (the majority id, not 0, read by ``min_share`` of at least ``min_seen``
    visible points)."""

    __slots__ = ("reads", "vote")

    def __init__(self, reads: dict[int, dict[int, int]], min_seen: int, min_share: float) -> None:
        self.reads = reads
        self.vote: dict[int, int] = {}
        for t, ids in reads.items():
            total = sum(ids.values())
            best = max(ids, key=lambda i: (ids[i], -i))
            if best > 0 and total >= min_seen and ids[best] >= min_share * total:
                self.vote[t] = best

    def merged(self, other: _RegionVotes, min_seen: int, min_share: float) -> _RegionVotes:
        reads = {t: dict(ids) for t, ids in self.reads.items()}
        for t, ids in other.reads.items():
            mine = reads.setdefault(t, {})
            for i, c in ids.items():
                mine[i] = mine.get(i, 0) + c
        return _RegionVotes(reads, min_seen, min_share)


def _agreement(a: _RegionVotes, b: _RegionVotes) -> tuple[int, int]:
    """Frames in which both regions cast a confident vote, and how many of those gave both the same id."""
    if len(a.vote) > len(b.vote):
        a, b = b, a
    both = same = 0
    for t, i in a.vote.items():
        j = b.vote.get(t)
        if j is not None:
            both += 1
            same += i == j
    return both, same


def consensus_regions(
    sp: ScanPoints, counts: FrameCounts, n_frames: int, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], dict[str, int]]:
    """Region [s] of each superpoint (0: none) by view consensus, and counts for the report.

    Touching masked superpoints are merged agglomeratively, the best agreeing pair first: two regions join
    when, among the frames in which both cast a confident vote (``consensus_min_frames`` or more), at least
    ``consensus_fraction`` give them the same id. A region votes with all its points, so once a book stack's
    superpoints have joined, one superpoint straddling the stack and its shelf (the fused surface is
    coarser than a book) reads the shelf's id in some frames and the stack's in others without bridging the
    two: the stack as a whole reads its own id, the shelf its own (single linkage over superpoint pairs,
    MaskClustering's graph before its iterative merging, joined them through it)."""
    g = sp.graph
    n = g.size
    votes = votes_from_counts(counts, n_frames, cfg.vote_min_points)
    voted = np.bincount(votes.sp, minlength=n)
    unmasked = np.bincount(votes.sp, (votes.mask_id == 0).astype(float), n)
    masked = (voted > 0) & (unmasked < cfg.unmasked_share * np.maximum(voted, 1))
    reads: dict[int, dict[int, dict[int, int]]] = {}
    for s_, t, i, c in zip(counts.sp.tolist(), counts.frame.tolist(), counts.mask_id.tolist(),
                           counts.count.tolist(), strict=True):  # fmt: skip
        if masked[s_]:
            reads.setdefault(s_, {}).setdefault(t, {})[i] = c
    seen, share = cfg.vote_min_points, cfg.vote_min_share
    state = {s_: _RegionVotes(r, seen, share) for s_, r in reads.items()}
    ok = (g.contacts >= cfg.min_contacts) & masked[g.pairs[:, 0]] & masked[g.pairs[:, 1]]
    neighbours: dict[int, set[int]] = {}
    for a, b in g.pairs[ok].tolist():
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    root, joined = _merge_by_consensus(
        state, neighbours, n, seen, share, cfg.consensus_min_frames, cfg.consensus_fraction
    )
    _, comp = np.unique(root, return_inverse=True)
    region = np.where(masked, comp + 1, 0)
    stats = {
        "superpoints": int(n),
        "contacts": int(len(g.pairs)),
        "joined_by_consensus": int(joined),
        "unseen_superpoints": int((voted == 0).sum()),
        "unmasked_superpoints": int(((voted > 0) & ~masked).sum()),
    }
    return region, stats


def _merge_by_consensus(
    state: dict[int, _RegionVotes],
    neighbours: dict[int, set[int]],
    n: int,
    seen: int,
    share: float,
    min_frames: int,
    fraction: float,
    size: tuple[NDArray[np.floating] | NDArray[np.integer], float] | None = None,
) -> tuple[NDArray[np.int64], int]:
    """Regions ``state`` (id -> its votes; ids below ``n``) merged agglomeratively along ``neighbours`` (id ->
    ids it may join), the best agreeing pair first: a pair joins while, among at least ``min_frames`` frames
    in which both cast a confident vote (``seen`` points, ``share`` of them), ``fraction`` give them the same
    id. ``size``: (each id's points [n], the least either of a pair must have), when a pair of small regions
    may not join. Both dicts are changed in place. Returns the root id of every id [n] and how many joined."""
    version = dict.fromkeys(state, 0)
    heap: list[tuple[float, int, int, int, int, int]] = []

    def push(a: int, b: int) -> None:
        if size is not None and max(size[0][a], size[0][b]) < size[1]:
            return
        both, same = _agreement(state[a], state[b])
        if both >= min_frames and same >= fraction * both:
            heapq.heappush(heap, (-same / both, -both, a, b, version[a], version[b]))

    for a, nb in neighbours.items():
        for b in nb:
            if a < b:
                push(a, b)
    parent = np.arange(n)
    joined = 0
    while heap:
        _, _, a, b, va, vb = heapq.heappop(heap)
        if version.get(a) != va or version.get(b) != vb:
            continue  # one of them has grown since
        state[a] = state[a].merged(state.pop(b), seen, share)
        del version[b]
        version[a] += 1
        parent[b] = a
        if size is not None:
            size[0][a] += size[0][b]
        joined += 1
        nb = (neighbours.pop(b, set()) | neighbours.get(a, set())) - {a, b}
        neighbours[a] = nb
        for c in nb:
            neighbours[c].discard(b)
            neighbours[c].add(a)
            push(a, c)
    for _ in range(64):
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    return parent, joined


def _region_gaps(sp: ScanPoints, region: NDArray[np.int64], gap: float) -> dict[int, set[int]]:
    """Regions [s] (0: none) whose points come within ``gap`` (m) of each other: {region: its near regions}.
    Pairs are tested only when their bounds, grown by ``gap``, overlap; then by a k-d tree of one region's
    points (scipy's ``cKDTree``)."""
    point_region = region[sp.graph.label]
    n = int(region.max(initial=0)) + 1
    order, bounds = points_by_region(point_region, n)
    pts = {r: sp.points[order[bounds[r] : bounds[r + 1]]] for r in range(1, n) if bounds[r + 1] > bounds[r]}
    lo = {r: p.min(axis=0) for r, p in pts.items()}
    hi = {r: p.max(axis=0) for r, p in pts.items()}
    trees: dict[int, cKDTree] = {}
    near: dict[int, set[int]] = {}
    ids = sorted(pts)
    for k, a in enumerate(ids):
        for b in ids[k + 1 :]:
            if np.any(lo[a] - gap > hi[b]) or np.any(lo[b] - gap > hi[a]):
                continue
            small, big = (a, b) if len(pts[a]) < len(pts[b]) else (b, a)
            if big not in trees:
                trees[big] = cKDTree(pts[big])
            if np.isfinite(trees[big].query(pts[small], k=1, distance_upper_bound=gap)[0]).any():
                near.setdefault(a, set()).add(b)
                near.setdefault(b, set()).add(a)
    return near


def bridge_gaps(
    sp: ScanPoints, region: NDArray[np.int64], counts: FrameCounts, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], int]:
    """Regions [s] (0: none) parted by a gap of unmasked or unfused surface join when the masks of most
    frames that see both give them one id: a table lamp's shade and base, whose 1-2 cm pole an eroded
    mask outline leaves unmasked in most frames, a floor lamp's shade and pole, a table top and a leg the
    fusion cut off. Regions whose points come within ``consensus_gap`` (m) are merged agglomeratively, the
    best agreeing pair first, while among at least ``gap_min_frames`` frames in which both cast a confident
    vote, ``gap_consensus_fraction`` give them the same id: stricter than the consensus of touching
    superpoints, since a 2D segmenter gives two separate objects one id only where they meet in an image.
    One of the two must be large enough to be kept (``masks_min_segment_points``): two fragments too small
    to be kept, joined, would pass the least size as a fragment still. ``counts``: the ids the points of each superpoint of ``sp`` read. Returns the regions and how many
    joined."""
    seen, share = cfg.vote_min_points, cfg.vote_min_share
    r = region[counts.sp]
    reads: dict[int, dict[int, dict[int, int]]] = {}
    for r_, t, i, c in zip(r.tolist(), counts.frame.tolist(), counts.mask_id.tolist(), counts.count.tolist(),
                           strict=True):  # fmt: skip
        if r_ > 0:
            frame = reads.setdefault(r_, {}).setdefault(t, {})
            frame[i] = frame.get(i, 0) + c
    state = {r_: _RegionVotes(x, seen, share) for r_, x in reads.items()}
    neighbours = {a: {b for b in nb if b in state} for a, nb in _region_gaps(sp, region, cfg.consensus_gap).items()}
    neighbours = {a: nb for a, nb in neighbours.items() if a in state}
    n = int(region.max(initial=0)) + 1
    # two fragments too small to be kept would make a fragment large enough to be kept
    size = (np.bincount(region, sp.graph.count, n), float(cfg.masks_min_segment_points))
    root, joined = _merge_by_consensus(
        state, neighbours, n, seen, share, cfg.gap_min_frames, cfg.gap_consensus_fraction, size
    )
    return root[region], joined


def region_votes(
    counts: FrameCounts, region: NDArray[np.int64], n_frames: int, cfg: SegmentConfig
) -> NDArray[np.int64]:
    """Each region's confident vote per frame [r + 1, T] (-1: none; row 0 is no region): the id most of
    its superpoints' voting points read there, not 0, read by ``vote_min_share`` of at least
    ``vote_min_points`` visible points. ``region`` [s]: the region of each superpoint of ``counts``."""
    n_regions = int(region.max(initial=0)) + 1
    table = np.full((n_regions, n_frames), -1, np.int64)
    r = region[counts.sp]
    keep = r > 0
    if not keep.any():
        return table
    key, ids, cnt = r[keep] * n_frames + counts.frame[keep], counts.mask_id[keep], counts.count[keep]
    span = int(ids.max(initial=0)) + 1
    uk, inv = np.unique(key * span + ids, return_inverse=True)
    total = np.bincount(inv, cnt)
    rk, rid = uk // span, uk % span
    order = np.lexsort((rid, -total, rk))  # per (region, frame) the most read id first, the lower on a tie
    rk, rid, total = rk[order], rid[order], total[order]
    first = np.flatnonzero(np.r_[True, rk[1:] != rk[:-1]])
    seen = np.add.reduceat(total, first)
    ok = (rid[first] > 0) & (seen >= cfg.vote_min_points) & (total[first] >= cfg.vote_min_share * seen)
    table[rk[first][ok] // n_frames, rk[first][ok] % n_frames] = rid[first][ok]
    return table


def split_straddling(
    sp: ScanPoints,
    region: NDArray[np.int64],
    votes: NDArray[np.int64],
    frame_masks: Sequence[NDArray | None],
    K: NDArray,
    world_from_cam: NDArray,
    depth: NDArray[np.float32],
    cfg: SegmentConfig,
) -> tuple[ScanPoints, NDArray[np.int64], int]:
    """Superpoints the masks consistently cut are split between the regions they straddle.

    A superpoint is coarser than a book (2.5 cm points), so one can hold a book stack's edge and the shelf's
    lip, or a lamp's base disc and the desk top under it. Every point of a superpoint touching another
    region reads its own mask id in each frame (``frame_counts``, with the depth test); it moves to a touching
    region when it reads that region's vote (``votes`` [r + 1, T] from ``region_votes``) in at least
    ``consensus_fraction`` of the frames (``consensus_min_frames`` or more) in which both see it, and its
    own region's in less than 1 - ``consensus_fraction``. Returns the scan points with the new superpoint
    graph, the region [s'] of each new superpoint and how many points moved."""
    g = sp.graph
    ra, rb = region[g.pairs[:, 0]], region[g.pairs[:, 1]]
    n_reg = votes.shape[0]
    # only a region large enough to be kept takes points: a fragment that grew on its neighbours' points
    # would pass the least size as a segment of its own
    kept = np.bincount(region, g.count, n_reg) >= cfg.masks_min_segment_points
    border = (ra > 0) & (rb > 0) & (ra != rb) & (g.contacts >= cfg.min_contacts)
    if not border.any():
        return sp, region, 0
    # (superpoint, candidate region) pairs: each border superpoint and the kept regions it touches
    to_b, to_a = border & kept[rb], border & kept[ra]
    cand = np.unique(np.r_[g.pairs[to_b, 0] * n_reg + rb[to_b], g.pairs[to_a, 1] * n_reg + ra[to_a]])
    if len(cand) == 0:
        return sp, region, 0
    cand_sp, cand_reg = cand // n_reg, cand % n_reg
    pts = np.flatnonzero(np.isin(g.label, cand_sp))
    reads = frame_counts(
        sp.points[pts], np.arange(len(pts)), frame_masks, K, world_from_cam, depth,
        cfg.depth_abs_tolerance, cfg.depth_rel_tolerance,
    )  # fmt: skip
    p_local, t, m = reads.sp, reads.frame, reads.mask_id
    own = region[g.label[pts]]
    v_own = votes[own[p_local], t]
    agree_own = np.bincount(p_local, (v_own >= 0) & (v_own == m), len(pts))
    own_rate = agree_own / np.maximum(np.bincount(p_local, v_own >= 0, len(pts)), 1)
    # every read against every candidate region of its point's superpoint
    starts = np.searchsorted(cand_sp, g.label[pts])
    per_read = (np.searchsorted(cand_sp, g.label[pts], side="right") - starts)[p_local]
    read_idx = np.repeat(np.arange(len(t)), per_read)
    slot = np.arange(len(read_idx)) - np.repeat(np.cumsum(per_read) - per_read, per_read)
    which = starts[p_local[read_idx]] + slot  # the (superpoint, region) candidate of each pairing
    v = votes[cand_reg[which], t[read_idx]]
    uk, inv = np.unique(p_local[read_idx] * len(cand) + which, return_inverse=True)
    agree = np.bincount(inv, (v >= 0) & (v == m[read_idx]))
    seen = np.bincount(inv, v >= 0)
    point, pair = uk // len(cand), uk % len(cand)
    ok = (seen >= cfg.consensus_min_frames) & (agree >= cfg.consensus_fraction * seen)
    ok &= own_rate[point] < 1.0 - cfg.consensus_fraction
    target = own.copy()
    score = agree / np.maximum(seen, 1)
    for i in np.flatnonzero(ok)[np.argsort(score[ok], kind="stable")].tolist():  # the best agreeing last
        target[point[i]] = cand_reg[pair[i]]
    moved = int((target != own).sum())
    if moved == 0:
        return sp, region, 0
    point_region = region[g.label]
    point_region[pts] = target
    sp, new_region, _ = regroup(sp, point_region)
    return sp, new_region, moved


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
    counts = frame_counts(
        sp.points[pick], sp.graph.label[pick], frame_masks, K, world_from_cam, depth,
        cfg.depth_abs_tolerance, cfg.depth_rel_tolerance,
    )  # fmt: skip
    seconds["votes"] = time.perf_counter() - t
    t = time.perf_counter()
    region, stats = consensus_regions(sp, counts, T, cfg)
    votes = region_votes(counts, region, T, cfg)
    sp, region, stats["points_moved_to_a_touching_region"] = split_straddling(
        sp, region, votes, frame_masks, K, world_from_cam, depth, cfg
    )
    pick = vote_sample(sp, cfg.vote_points, cfg.seed)
    counts = frame_counts(
        sp.points[pick], sp.graph.label[pick], frame_masks, K, world_from_cam, depth,
        cfg.depth_abs_tolerance, cfg.depth_rel_tolerance,
    )  # fmt: skip
    region, stats["joined_across_gaps"] = bridge_gaps(sp, region, counts, cfg)
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
