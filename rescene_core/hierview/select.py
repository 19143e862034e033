"""HierView view selection (paper Sec. 3.2, Appendix 'HierView Details') and the paper's baselines.

For every instance i the candidates are the frames where its mask is non-empty. Stages:

1. visibility: keep views with mask area >= a_min pixels and bbox area / image area >= b_min;
2. semantic: keep views with probability >= tau_s or semantic rank <= 3, at least 2 when available;
3. completeness: Comp(v; i) = fraction of (up to 30000) instance points whose projection falls inside
   m_{i,v}; choose the best (ties: the larger mask).

A stage that removes every candidate falls back to the best candidate of the previous stage. Baselines:
``largest_mask`` (the largest non-empty mask) and ``completeness_only`` (visibility, then completeness).

Areas, bounding boxes and completeness of all instances are computed in one pass over the frames: each
mask frame is read once and all sampled points of all instances are projected into it at once.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.capture import Capture
from rescene_core.config import HierViewConfig
from rescene_core.hierview.projection import LabelTable, mask_stats, points_in_mask
from rescene_core.hierview.semantic import SemanticScorer, make_scorer
from rescene_core.records import InstanceId, Missing, Stage, ViewChoice

log = logging.getLogger(__name__)

STAGE = Stage.VIEW


@dataclass(frozen=True)
class FrameStats:
    """Per-frame statistics of the tracked instances.

    table: compact labels of the instances. area: int64 [T, N] mask pixels. bbox: int64 [T, N] bounding-box
    pixels. completeness: float64 [T, N] fraction of the instance's sampled points inside its mask.
    points_used: int64 [N] sampled points per instance. image_pixels: W * H.
    """

    table: LabelTable
    area: NDArray[np.int64]
    bbox: NDArray[np.int64]
    completeness: NDArray[np.float64]
    points_used: NDArray[np.int64]
    image_pixels: int


def sample_instance_points(
    capture: Capture, table: LabelTable, max_points: int, seed: int = 0
) -> tuple[NDArray[np.float32], NDArray[np.int32], NDArray[np.int64]]:
    """Up to ``max_points`` finite points per tracked instance (world, metres).

    Returns (points [m, 3] float32, owner [m] compact label 1..N, count per instance [N]).
    """
    rng = np.random.default_rng(seed)
    chunks: list[NDArray[np.float32]] = []
    owners: list[NDArray[np.int32]] = []
    counts = np.zeros(table.n, np.int64)
    for k, inst_id in enumerate(table.ids):
        pts = capture.point_cloud(int(inst_id)).points
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts) > max_points:
            pts = pts[np.sort(rng.choice(len(pts), max_points, replace=False))]
        counts[k] = len(pts)
        chunks.append(np.asarray(pts, np.float32))
        owners.append(np.full(len(pts), k + 1, np.int32))
    if not chunks:
        return np.zeros((0, 3), np.float32), np.zeros(0, np.int32), counts
    return np.concatenate(chunks), np.concatenate(owners), counts


def frame_stats(capture: Capture, instance_ids: list[int], max_points: int) -> FrameStats:
    """Areas, bounding boxes and completeness of the given instances in every frame (one pass)."""
    table = LabelTable.build(instance_ids)
    n, t_count = table.n, capture.num_frames
    width, height = capture.image_size
    points, owner, counts = sample_instance_points(capture, table, max_points)
    area = np.zeros((t_count, n), np.int64)
    bbox = np.zeros((t_count, n), np.int64)
    hits = np.zeros((t_count, n), np.int64)
    for t in range(t_count):
        labels = table.compact(capture.instance_masks[t])
        area[t], bbox[t] = mask_stats(labels, n)
        if len(points) and np.isfinite(capture.world_from_cam[t]).all() and np.isfinite(capture.K[t]).all():
            hits[t] = points_in_mask(labels, points, owner, capture.K[t], capture.world_from_cam[t], n)
    completeness = hits / np.maximum(counts, 1)[None, :]
    return FrameStats(table, area, bbox, completeness, counts, width * height)


def _best(frames: NDArray[np.int64], key: NDArray[np.float64], area: NDArray[np.int64]) -> int:
    """Index into ``frames`` of the highest key; ties go to the larger mask, then the earlier frame."""
    order = np.lexsort((frames, -area, -key))
    return int(order[0])


def _select_one(
    inst_id: int,
    k: int,
    stats: FrameStats,
    config: HierViewConfig,
    semantic: dict[int, NDArray[np.float64]],
    backend_name: str,
    backend_note: str,
    calibrated: bool = True,
) -> ViewChoice | Missing:
    area = stats.area[:, k]
    frames = np.flatnonzero(area > 0)
    if len(frames) == 0:
        return Missing(InstanceId(inst_id), STAGE, "instance is seen in no frame (no non-empty mask)")
    a = area[frames]
    bbox_ratio = stats.bbox[frames, k] / stats.image_pixels
    comp = stats.completeness[frames, k]
    has_points = stats.points_used[k] > 0
    visible = (a >= config.min_mask_area) & (bbox_ratio >= config.min_bbox_ratio)
    sem = semantic.get(inst_id)
    sem_full = np.full(len(frames), np.nan)
    rank_full = np.zeros(len(frames), np.int64)
    kept = np.zeros(len(frames), bool)
    method = config.method
    notes: list[str] = []

    if method == "largest_mask":
        choice = _best(frames, a.astype(np.float64), a)
        stage_reached = np.where(visible, "visibility", "candidate")
        reason = f"largest mask ({int(a[choice])} px) among {len(frames)} non-empty views"
        used_backend = "none"
    else:
        stage_reached = np.where(visible, "visibility", "candidate").astype(object)
        if not visible.any():
            choice = _best(frames, a.astype(np.float64), a)
            reason = (
                f"no view passed visibility (area >= {config.min_mask_area} px and bbox/image >= "
                f"{config.min_bbox_ratio}); fell back to the largest of {len(frames)} non-empty views"
            )
            used_backend = backend_name if method == "hierview" else "none"
            rows = _rows(frames, a, bbox_ratio, sem_full, rank_full, comp, stage_reached)
            return ViewChoice(InstanceId(inst_id), int(frames[choice]), method, reason, rows, used_backend)
        vis_idx = np.flatnonzero(visible)
        pool = vis_idx
        if method == "hierview":
            used_backend = backend_name
            if backend_note:
                notes.append(backend_note)
            if sem is not None and backend_name != "none":
                s = np.asarray(sem, dtype=np.float64)
                sem_full[vis_idx] = s
                order = np.lexsort((frames[vis_idx], -a[vis_idx], -s))
                rank = np.empty(len(vis_idx), np.int64)
                rank[order] = np.arange(1, len(vis_idx) + 1)
                rank_full[vis_idx] = rank
                keep = (s >= config.tau_s) | (rank <= config.semantic_rank_keep)
                if not calibrated:
                    # a score that only ranks this instance's views: tau_s means nothing to it, and the top
                    # ranks alone keep near-ties (close-up crops of large furniture); the better half passes
                    keep |= s >= np.median(s)
                if keep.sum() < config.semantic_min_keep:
                    keep = rank <= min(config.semantic_min_keep, len(vis_idx))
                pool = vis_idx[keep]
                median_rule = "" if calibrated else " or p >= the instance's median"
                notes.append(
                    f"semantic ({backend_name}) kept {len(pool)}/{len(vis_idx)} views "
                    f"(p >= {config.tau_s} or rank <= {config.semantic_rank_keep}{median_rule})"
                )
            else:
                notes.append("no semantic stage")
            stage_reached[pool] = "semantic"
        else:
            used_backend = "none"
        kept[pool] = True
        if not has_points:
            # Completeness needs P_i: fall back to the best of the previous stage.
            prev_key = sem_full[pool] if np.isfinite(sem_full[pool]).all() else a[pool].astype(np.float64)
            choice = int(pool[_best(frames[pool], prev_key, a[pool])])
            reason = "; ".join(
                [*notes, "instance has no finite points: fell back to the best view of the previous stage"]
            )
        else:
            stage_reached[pool] = "completeness"
            # Ties in completeness go to the semantically more consistent view, then the larger mask.
            tie = np.nan_to_num(sem_full[pool], nan=0.0)
            order = np.lexsort((frames[pool], -a[pool], -tie, -np.round(comp[pool], 9)))
            best = int(pool[order[0]])
            if comp[best] <= 0:
                prev_key = sem_full[pool] if np.isfinite(sem_full[pool]).all() else a[pool].astype(np.float64)
                choice = int(pool[_best(frames[pool], prev_key, a[pool])])
                reason = "; ".join(
                    [
                        *notes,
                        "no instance point projects into any kept mask: fell back to the best view of the previous stage",
                    ]
                )
            else:
                choice = best
                reason = "; ".join(
                    [*notes, f"highest completeness {comp[best]:.3f} among {len(pool)} views (mask {int(a[best])} px)"]
                )
    rows = _rows(frames, a, bbox_ratio, sem_full, rank_full, comp, stage_reached)
    return ViewChoice(InstanceId(inst_id), int(frames[choice]), method, reason, rows, used_backend)


def _rows(frames, area, bbox_ratio, sem, rank, comp, stage_reached) -> tuple[dict[str, Any], ...]:
    return tuple(
        {
            "frame": int(frames[j]),
            "area": int(area[j]),
            "bbox_ratio": round(float(bbox_ratio[j]), 6),
            "semantic": None if not np.isfinite(sem[j]) else round(float(sem[j]), 6),
            "semantic_rank": int(rank[j]) if rank[j] > 0 else None,
            "completeness": round(float(comp[j]), 6),
            "stage_reached": str(stage_reached[j]),
        }
        for j in range(len(frames))
    )


def select_views(
    capture: Capture,
    config: HierViewConfig | None = None,
    instance_ids: list[int] | None = None,
    scorer: SemanticScorer | None = None,
) -> dict[int, ViewChoice | Missing]:
    """Choose one view per instance with ``config.method`` (HierView or a baseline).

    instance_ids: which instances (default: the capture's non-structural instances). scorer: an explicit
    semantic scorer (default: built from the config; a missing CLIP falls back as configured and the
    choice's reason says so). Returns instance id -> ViewChoice, or Missing with the reason.
    """
    config = config or HierViewConfig()
    known = {int(i.id) for i in capture.instances} | {int(i) for i in capture.point_ids}
    if instance_ids is None:
        instance_ids = [int(i.id) for i in capture.object_instances]
    out: dict[int, ViewChoice | Missing] = {}
    wanted = []
    for inst_id in instance_ids:
        if int(inst_id) <= 0:
            out[int(inst_id)] = Missing(InstanceId(int(inst_id)), STAGE, "instance ids must be > 0")
        elif int(inst_id) not in known:
            out[int(inst_id)] = Missing(InstanceId(int(inst_id)), STAGE, "instance is not in the capture")
        else:
            wanted.append(int(inst_id))
    if not wanted:
        return out
    stats = frame_stats(capture, wanted, config.max_points)
    semantic: dict[int, NDArray[np.float64]] = {}
    backend_name, note, calibrated = "none", "", True
    if config.method == "hierview":
        if scorer is None:
            scorer, note = make_scorer(config)
        backend_name = scorer.name
        calibrated = bool(getattr(scorer, "calibrated", True))
        requests: dict[int, NDArray[np.int64]] = {}
        for inst_id in wanted:
            k = stats.table.index_of(inst_id)
            visible = (stats.area[:, k] >= config.min_mask_area) & (
                stats.bbox[:, k] / stats.image_pixels >= config.min_bbox_ratio
            )
            if visible.any():
                requests[inst_id] = np.flatnonzero(visible)
        try:
            semantic = scorer.score(capture, requests) if requests else {}
        except Exception as err:  # a scorer failing at run time must not lose the instances
            note = f"semantic scorer '{backend_name}' failed ({type(err).__name__}: {err}); no semantic stage"
            log.warning("HierView: %s", note)
            semantic, backend_name = {}, "none"
    for inst_id in wanted:
        k = stats.table.index_of(inst_id)
        out[inst_id] = _select_one(inst_id, k, stats, config, semantic, backend_name, note, calibrated)
    return out
