"""What a panoptic multi-view reconstruction would output, with its typical errors (dialled by a preset).

Per frame: depth noise growing with distance and dropouts, label noise in a band along mask boundaries,
now and then one mask drifting onto a neighbouring object. Per object (decided once, so they hold in every
frame): a split into two instances, a small object missed altogether, a wrong label.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from rescene_core.capture.synth.objects import CONFUSABLE
from rescene_core.capture.synth.presets import SynthPreset

OBJECT_RENDER_BASE = 1 << 14
"""Render ids of objects are OBJECT_RENDER_BASE + object id; structure renders with its instance id."""


@dataclass
class FrameErrors:
    """Errors applied to one frame (for the capture's attrs and for tests)."""

    drift: list[dict] = field(default_factory=list)
    boundary_pixels: int = 0


def depth_with_noise(depth: NDArray[np.float32], preset: SynthPreset, rng: np.random.Generator) -> NDArray[np.float32]:
    """Noisy metric depth [H, W]: sigma(z) = base + quadratic * z^2, plus random dropouts (0 = invalid)."""
    sigma = preset.depth_noise_base + preset.depth_noise_quadratic * depth.astype(np.float32) ** 2
    noisy = depth + rng.standard_normal(depth.shape, dtype=np.float32) * sigma
    valid = depth > 0
    if preset.depth_dropout > 0:
        valid &= rng.random(depth.shape, dtype=np.float32) >= preset.depth_dropout
    return np.where(valid & (noisy > 0), noisy, 0.0).astype(np.float32)


def boundary_noise(
    ids: NDArray[np.int32], preset: SynthPreset, rng: np.random.Generator
) -> tuple[NDArray[np.int32], int]:
    """Labels in a band along boundaries take a random neighbour's label with ``mask_boundary_prob``."""
    r = max(1, int(round(preset.mask_boundary_px * ids.shape[1] / 640)))
    if preset.mask_boundary_prob <= 0 or preset.mask_boundary_px <= 0:
        return ids, 0
    edge = np.zeros(ids.shape, np.uint8)
    edge[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    edge[1:] |= ids[1:] != ids[:-1]
    band = ndimage.maximum_filter(edge, size=2 * r) > 0
    ys, xs = np.nonzero(band)
    pick = rng.random(len(ys)) < preset.mask_boundary_prob
    ys, xs = ys[pick], xs[pick]
    dy = rng.integers(-r, r + 1, len(ys))
    dx = rng.integers(-r, r + 1, len(ys))
    h, w = ids.shape
    out = ids.copy()
    out[ys, xs] = ids[np.clip(ys + dy, 0, h - 1), np.clip(xs + dx, 0, w - 1)]
    return out, int((out != ids).sum())


def shift(mask: NDArray[np.bool_], dy: int, dx: int) -> NDArray[np.bool_]:
    """The boolean image shifted by (dy, dx) pixels, padding with False."""
    h, w = mask.shape
    out = np.zeros_like(mask)
    ys, yd = (slice(0, h - dy), slice(dy, h)) if dy >= 0 else (slice(-dy, h), slice(0, h + dy))
    xs, xd = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
    out[yd, xd] = mask[ys, xs]
    return out


def drift(
    ids: NDArray[np.int32],
    object_ids: set[int],
    preset: SynthPreset,
    rng: np.random.Generator,
    min_pixels: int,
) -> tuple[NDArray[np.int32], dict | None]:
    """With ``drift_frame_prob``, one object mask slides onto a neighbouring object's pixels.

    Returns the new ids and the event ({"instance", "onto", "pixels"}) or None.
    """
    if rng.random() >= preset.drift_frame_prob:
        return ids, None
    counts = np.bincount(ids.ravel())
    visible = [int(i) for i in np.flatnonzero(counts >= min_pixels) if int(i) in object_ids]
    if len(visible) < 2:
        return ids, None
    d = max(2, int(round(preset.drift_px * ids.shape[1] / 640)))
    h, w = ids.shape
    flat = ids.ravel()
    cy = np.bincount(flat, weights=np.repeat(np.arange(h, dtype=np.float64), w), minlength=len(counts))
    cx = np.bincount(flat, weights=np.tile(np.arange(w, dtype=np.float64), h), minlength=len(counts))
    centre = np.stack([cy, cx], 1) / np.maximum(counts, 1)[:, None]
    for k in rng.permutation(len(visible))[:3]:
        a = visible[int(k)]
        ma = ids == a
        best = None
        for b in visible:
            if b == a:
                continue
            v = centre[b] - centre[a]
            v = v / max(np.linalg.norm(v), 1e-9)
            moved = shift(ma, int(round(v[0] * d)), int(round(v[1] * d)))
            onto = moved & (ids == b)
            n = int(onto.sum())
            if n >= max(10, min_pixels // 4) and (best is None or n > best[1]):
                best = (b, n, onto)
        if best is not None:
            out = ids.copy()
            out[best[2]] = a
            return out, {"instance": a, "onto": best[0], "pixels": best[1]}
    return ids, None


@dataclass
class PanopticPlan:
    """The per-object decisions of the panoptic model, taken once so they hold in every frame.

    primary_of: object id -> its instance id. split_of: object id -> (second instance id, object-frame
    axis, threshold) for objects split in two along that axis. missed: objects the model never reports.
    labels: object id -> the wrong label it reports. events: the decisions as capture-attrs records.
    next_id: the first unused instance id.
    """

    primary_of: dict[int, int]
    split_of: dict[int, tuple[int, int, float]]
    missed: set[int]
    labels: dict[int, str]
    events: list[dict]
    next_id: int

    def render_lut(self, structure_ids: list[int], objects: list) -> NDArray[np.int32]:
        """Render id -> reported instance id (0 for missed objects), before splits and per-frame errors."""
        lut = np.zeros(OBJECT_RENDER_BASE + len(objects) + 1, np.int32)
        for iid in structure_ids:
            lut[iid] = iid
        for obj in objects:
            if obj.object_id not in self.missed:
                lut[OBJECT_RENDER_BASE + obj.object_id] = self.primary_of[obj.object_id]
        return lut

    def object_instance_ids(self) -> set[int]:
        """Instance ids the model reports for objects (primaries of the objects not missed, and split halves)."""
        primaries = {self.primary_of[o] for o in self.primary_of if o not in self.missed}
        return primaries | {v[0] for v in self.split_of.values()}

    def instances_of(self, object_id: int) -> list[int]:
        """Instance ids reported for one object: none when missed, its primary and its split half if split."""
        if object_id in self.missed:
            return []
        second = [self.split_of[object_id][0]] if object_id in self.split_of else []
        return [self.primary_of[object_id], *second]

    def apply_splits(
        self,
        render_ids: NDArray[np.int32],
        ids: NDArray[np.int32],
        points: NDArray,
        local_from_world: dict[int, NDArray[np.float64]],
    ) -> None:
        """Relabel, in place, the pixels of split objects beyond their threshold with the second instance id.

        render_ids, ids: int32 [H, W]; points: [H, W, 3] world hit points; local_from_world: object id ->
        object_from_world 4x4 of each split object.
        """
        for oid, (second, axis, thr) in self.split_of.items():
            sel = render_ids == OBJECT_RENDER_BASE + oid
            if sel.any():
                p = points[sel].astype(np.float64)
                local = p @ local_from_world[oid][:3, :3].T + local_from_world[oid][:3, 3]
                ids[sel] = np.where(local[:, axis] > thr, second, ids[sel])


def plan_panoptic_errors(
    objects: list,
    n_structure: int,
    preset: SynthPreset,
    rng_err: np.random.Generator,
    rng_ids: np.random.Generator,
) -> PanopticPlan:
    """Instance ids (a random order after the structure's), misses of small objects nothing stands on,
    splits of large objects, wrong labels of confusable ones, as the preset's probabilities say.

    objects: the layout's placed objects (``object_id``, ``label``, ``model``, ``parent``), object ids 1..n.
    """
    events: list[dict] = []
    n_obj = len(objects)
    perm = rng_ids.permutation(n_obj)
    primary_of = {objects[int(k)].object_id: n_structure + 1 + j for j, k in enumerate(perm)}
    next_id = n_structure + n_obj + 1
    split_of: dict[int, tuple[int, int, float]] = {}
    missed: set[int] = set()
    labels: dict[int, str] = {}
    for obj in objects:
        size = obj.model.size
        label = obj.label
        if max(size) < preset.small_size and not any(o.parent == obj.object_id for o in objects):
            if rng_err.random() < preset.miss_small_prob:
                missed.add(obj.object_id)
                events.append({"kind": "missed", "object": obj.object_id, "label": label})
                continue
        if max(size) >= preset.split_min_size and rng_err.random() < preset.split_prob:
            axis = int(np.argmax(size[:2]))
            lo, hi = obj.model.bounds[0][axis], obj.model.bounds[1][axis]
            thr = float(lo + (hi - lo) * rng_err.uniform(0.35, 0.65))
            split_of[obj.object_id] = (next_id, axis, thr)
            events.append({"kind": "split", "object": obj.object_id, "instances": [primary_of[obj.object_id], next_id]})
            next_id += 1
        if rng_err.random() < preset.wrong_label_prob and label in CONFUSABLE:
            wrong = CONFUSABLE[label][int(rng_err.integers(len(CONFUSABLE[label])))]
            labels[obj.object_id] = wrong
            events.append({"kind": "wrong_label", "object": obj.object_id, "label": label, "given": wrong})
    return PanopticPlan(primary_of, split_of, missed, labels, events, next_id)


@dataclass
class Accumulator:
    """Fuses masked, noisy depth of many frames into per-instance voxel-averaged point clouds.

    voxel_of: float64 [max_id + 1] voxel size (m) per instance id.
    """

    voxel_of: NDArray[np.float64]
    stride: int
    batch: int = 16
    _keys: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    _sums: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 7)))
    _pending: list = field(default_factory=list)

    def add(self, depth: NDArray, ids: NDArray, rgb: NDArray, K: NDArray, world_from_cam: NDArray) -> None:
        """Back-project the valid, labelled pixels of one frame and accumulate them."""
        self.push(*self.frame_points(depth, ids, rgb, K, world_from_cam))

    def frame_points(
        self, depth: NDArray, ids: NDArray, rgb: NDArray, K: NDArray, world_from_cam: NDArray
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Voxel keys [n] and (x, y, z, r, g, b, 1) rows [n, 7] of one frame's valid, labelled pixels
        (every ``stride``-th pixel); pure, so frames can be processed in parallel."""
        s = self.stride
        d, m = depth[::s, ::s], ids[::s, ::s]
        vs, us = np.nonzero((d > 0) & (m > 0))
        z = d[vs, us]
        x = ((us * s + 0.5 - K[0, 2]) / K[0, 0]).astype(np.float32) * z
        y = ((vs * s + 0.5 - K[1, 2]) / K[1, 1]).astype(np.float32) * z
        rot = world_from_cam[:3, :3].astype(np.float32)
        pw = np.empty((len(z), 7), np.float64)
        pw[:, :3] = np.stack([x, y, z], axis=1) @ rot.T + world_from_cam[:3, 3].astype(np.float32)
        pw[:, 3:6] = rgb[vs * s, us * s]
        pw[:, 6] = 1.0
        inst = m[vs, us].astype(np.int64)
        q = np.floor(pw[:, :3] / self.voxel_of[inst][:, None]).astype(np.int64) + 32768
        key = (inst << 48) | (q[:, 0] << 32) | (q[:, 1] << 16) | q[:, 2]
        return key, pw

    def push(self, key: NDArray[np.int64], values: NDArray[np.float64]) -> None:
        """Accumulate one frame's ``frame_points`` (call in frame order for identical sums)."""
        self._pending.append((key, values))
        if len(self._pending) >= self.batch:
            self._reduce()

    def _reduce(self) -> None:
        if not self._pending:
            return
        keys = np.concatenate([self._keys] + [k for k, _ in self._pending])
        vals = np.concatenate([self._sums] + [v for _, v in self._pending])
        self._pending = []
        uniq, inv = np.unique(keys, return_inverse=True)
        sums = np.stack([np.bincount(inv, weights=vals[:, j], minlength=len(uniq)) for j in range(7)], axis=1)
        self._keys, self._sums = uniq, sums

    def clouds(self) -> dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]]:
        """Instance id -> (points float32 [n, 3] world metres, colours uint8 [n, 3]), voxel means."""
        self._reduce()
        inst = (self._keys >> 48).astype(np.int64)
        mean = self._sums[:, :6] / self._sums[:, 6:7]
        out = {}
        bounds = np.flatnonzero(np.diff(inst)) + 1
        for chunk in np.split(np.arange(len(inst)), bounds):
            if len(chunk) == 0:
                continue
            i = int(inst[chunk[0]])
            out[i] = (
                mean[chunk, :3].astype(np.float32),
                np.clip(np.round(mean[chunk, 3:6]), 0, 255).astype(np.uint8),
            )
        return out
