"""Key frames for relation inference by greedy marginal 3D coverage (paper Appendix 'Key-Frame Selection').

The instance points are sampled (at most ``max_points``, confidence >= ``min_confidence``), voxelised at
``voxel size = shortest side of the sampled box / voxel_divisor`` (>= ``min_voxel_size``), and every
(voxel, instance) pair becomes one coverage unit at its voxel centre. A unit is covered by frame t when its
centre projects inside the instance's mask m_{i,t}. A frame is eligible when its mask-match ratio (covered
units / units projecting into the image) is >= ``min_mask_match`` and it covers >= ``min_visible_instances``
instances; with fewer eligible frames than the budget, all frames that cover anything are eligible
(``fallback``). Frames are added greedily by the number of newly covered units until the budget is reached
or nothing new is covered.

Captures carry no per-point confidence, so every point has confidence 1.0 and the confidence filter keeps
all points; a capture that adds a confidence array would be filtered here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.capture import Capture
from rescene_core.config import KeyFrameConfig
from rescene_core.hierview.projection import LabelTable, project_to_pixels


@dataclass(frozen=True)
class KeyFrames:
    """The chosen key frames and how they were chosen.

    frames: chosen frame indices in selection order. gains: newly covered units per chosen frame.
    voxel_size: metres. fallback: True when too few frames passed the eligibility filters.
    eligible: frames that passed the filters. units: coverage units in all. covered: units covered by the
    key frames. coverable: units covered by any frame. mask_match: float [T] per-frame mask-match ratio.
    visible_instances: int [T] instances with a covered unit per frame.
    """

    frames: tuple[int, ...]
    gains: tuple[int, ...]
    voxel_size: float
    fallback: bool
    eligible: tuple[int, ...]
    units: int
    covered: int
    coverable: int
    mask_match: tuple[float, ...]
    visible_instances: tuple[int, ...]
    reason: str = ""

    @property
    def coverage_ratio(self) -> float:
        """Units covered by the key frames over units covered by any frame (1.0 when nothing is coverable)."""
        return self.covered / self.coverable if self.coverable else 1.0

    def to_json(self) -> dict[str, Any]:
        return {
            "frames": list(self.frames),
            "gains": list(self.gains),
            "voxel_size": self.voxel_size,
            "fallback": self.fallback,
            "eligible": list(self.eligible),
            "units": self.units,
            "covered": self.covered,
            "coverable": self.coverable,
            "coverage_ratio": self.coverage_ratio,
            "mask_match": list(self.mask_match),
            "visible_instances": list(self.visible_instances),
            "reason": self.reason,
            "confidence": "captures carry no point confidence; every point counts as 1.0",
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> KeyFrames:
        return cls(
            frames=tuple(int(f) for f in d["frames"]),
            gains=tuple(int(g) for g in d["gains"]),
            voxel_size=float(d["voxel_size"]),
            fallback=bool(d["fallback"]),
            eligible=tuple(int(f) for f in d["eligible"]),
            units=int(d["units"]),
            covered=int(d["covered"]),
            coverable=int(d["coverable"]),
            mask_match=tuple(float(v) for v in d["mask_match"]),
            visible_instances=tuple(int(v) for v in d["visible_instances"]),
            reason=str(d.get("reason", "")),
        )


def coverage_units(
    capture: Capture, config: KeyFrameConfig
) -> tuple[NDArray[np.float32], NDArray[np.int32], float, LabelTable]:
    """Voxel-centre coverage units: (centres [u, 3] world metres, owner [u] compact label, voxel size, table)."""
    ids = [int(i.id) for i in (capture.instances if config.include_structural else capture.object_instances)]
    table = LabelTable.build(ids)
    points, point_ids = capture.all_points()
    keep = np.isin(point_ids, table.ids) & np.isfinite(points).all(axis=1)
    # Captures have no confidence array: every point has confidence 1.0 >= min_confidence.
    confidence = np.ones(len(points), np.float32)
    keep &= confidence >= config.min_confidence
    points, point_ids = points[keep], point_ids[keep]
    if len(points) > config.max_points:
        rng = np.random.default_rng(config.seed)
        pick = np.sort(rng.choice(len(points), config.max_points, replace=False))
        points, point_ids = points[pick], point_ids[pick]
    if len(points) == 0:
        return np.zeros((0, 3), np.float32), np.zeros(0, np.int32), float(config.min_voxel_size), table
    lo = points.min(axis=0).astype(np.float64)
    extent = points.max(axis=0).astype(np.float64) - lo
    voxel = max(float(extent.min()) / config.voxel_divisor, config.min_voxel_size)
    keys = np.floor((points - lo) / voxel).astype(np.int64)
    owner = table.lut[point_ids].astype(np.int64)
    unique = np.unique(np.column_stack([keys, owner]), axis=0)
    centres = (lo + (unique[:, :3] + 0.5) * voxel).astype(np.float32)
    return centres, unique[:, 3].astype(np.int32), voxel, table


def coverage_matrix(
    capture: Capture,
    centres: NDArray[np.float32],
    owner: NDArray[np.int32],
    table: LabelTable,
    occlusion_margin: float | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.int64]]:
    """covered [T, u], mask-match ratio [T] and visible-instance count [T] (each mask frame read once).

    With ``occlusion_margin`` (m) and capture depth, a unit whose centre lies more than the margin behind the
    observed depth at its pixel is occluded by something else: it is left out of the mask-match denominator
    instead of counting as a mismatch (it cannot be in its own mask in that frame).
    """
    t_count = capture.num_frames
    width, height = capture.image_size
    covered = np.zeros((t_count, len(centres)), bool)
    match = np.zeros(t_count)
    visible = np.zeros(t_count, np.int64)
    if len(centres) == 0:
        return covered, match, visible
    for t in range(t_count):
        if not (np.isfinite(capture.world_from_cam[t]).all() and np.isfinite(capture.K[t]).all()):
            continue
        col, row, valid = project_to_pixels(centres, capture.K[t], capture.world_from_cam[t], width, height)
        if not valid.any():
            continue
        labels = table.compact(capture.instance_masks[t])
        hit = valid & (labels[row, col] == owner)
        seen = valid
        if occlusion_margin is not None and capture.depth is not None:
            observed = np.nan_to_num(np.asarray(capture.depth[t])[row, col], nan=0.0)
            z = _camera_depth(centres, capture.world_from_cam[t])
            seen = valid & ~((observed > 0) & (z > observed + occlusion_margin))
        covered[t] = hit
        match[t] = hit.sum() / seen.sum() if seen.any() else 0.0
        visible[t] = len(np.unique(owner[hit]))
    return covered, match, visible


def _camera_depth(points_world: NDArray[np.float32], world_from_cam: NDArray[np.float64]) -> NDArray[np.float64]:
    """Depth along camera z (m) of world points [n, 3]."""
    rot, centre = world_from_cam[:3, :3], world_from_cam[:3, 3]
    return (np.asarray(points_world, np.float64) - centre) @ rot[:, 2]


def select_keyframes(capture: Capture, config: KeyFrameConfig | None = None) -> KeyFrames:
    """Greedy marginal-coverage key frames (see the module docstring)."""
    config = config or KeyFrameConfig()
    centres, owner, voxel, table = coverage_units(capture, config)
    margin = config.occlusion_margin if config.occlusion_aware else None
    covered, match, visible = coverage_matrix(capture, centres, owner, table, margin)
    any_cover = covered.any(axis=1)
    eligible = np.flatnonzero((match >= config.min_mask_match) & (visible >= config.min_visible_instances) & any_cover)
    fallback = len(eligible) < config.budget
    if fallback:
        eligible = np.flatnonzero(any_cover)
    chosen: list[int] = []
    gains: list[int] = []
    done = np.zeros(len(centres), bool)
    pool = covered[eligible]
    for _ in range(min(config.budget, len(eligible))):
        gain = (pool & ~done).sum(axis=1)
        gain[np.isin(eligible, chosen)] = -1
        j = int(np.argmax(gain))
        if gain[j] <= 0:
            break
        chosen.append(int(eligible[j]))
        gains.append(int(gain[j]))
        done |= pool[j]
    coverable = int(covered.any(axis=0).sum())
    if len(centres) == 0:
        reason = "no instance points to cover"
    elif not chosen:
        reason = "no frame covers any voxel"
    else:
        reason = f"{len(chosen)} frames by greedy coverage from {len(eligible)} " + (
            "frames covering anything (fewer than the budget passed the filters)" if fallback else "eligible frames"
        )
    return KeyFrames(
        frames=tuple(chosen),
        gains=tuple(gains),
        voxel_size=voxel,
        fallback=bool(fallback),
        eligible=tuple(int(e) for e in eligible),
        units=len(centres),
        covered=int(done.sum()),
        coverable=coverable,
        mask_match=tuple(float(m) for m in match),
        visible_instances=tuple(int(v) for v in visible),
        reason=reason,
    )
