"""Geometry metrics as the field reports them (the MonoSDF / DP-Recon protocol, paper Appendix
'Geometry Metrics').

Both surfaces become point sets, either

- ``sampled``: points drawn uniformly on the mesh surfaces (area-weighted, face normals), or
- ``refused``: depth rendered along the capture's cameras (``rescene_core.render.RayCaster``) and fused
  (``fuse_depth``: back-projected, averaged per voxel): surfaces no camera saw (the insides of
  furniture, the backs against walls) do not count;

then both are downsampled to ``voxel_size`` voxels (2 cm). With d(p, Q) the distance from p to its
nearest neighbour in Q:

- accuracy = mean over predicted points of d(p, reference), completion = mean over reference points of
  d(q, prediction), Chamfer = (accuracy + completion) / 2 (metres);
- precision@t = fraction of predicted points with d < t, recall@t = fraction of reference points with
  d < t, F@t = 2 P R / (P + R), for t = 5 cm and 10 cm;
- normal consistency = mean over both directions of |cos| between a point's normal and its nearest
  neighbour's normal;
- centre offset = distance between the centres of the two point sets' bounding boxes (m).

Frames: world metres, z up. The sensor reference of a capture with depth is ``fuse_depth`` of its own
depth frames; fused points are labelled with the capture instance of the nearest instance point.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image
from pydantic import BaseModel, ConfigDict
from scipy.spatial import cKDTree

from rescene_core.export import ExportConfig, shell_meshes
from rescene_core.records import Camera
from rescene_core.render import RayCaster, RenderMesh


class GeometryConfig(BaseModel):
    """Sampling, downsampling, thresholds and re-fusion of the geometry metrics."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    voxel_size: float = 0.02
    """Voxel downsampling of both point sets before the distances (m; MonoSDF / DP-Recon use 2 cm)."""
    thresholds: tuple[float, ...] = (0.05, 0.10)
    """Distance thresholds of precision, recall and F-score (m; the paper reports F@5 cm)."""
    samples_per_m2: float = 10000.0
    """Surface samples per square metre in the ``sampled`` mode (before downsampling)."""
    min_samples: int = 200
    """Fewest samples of one mesh in the ``sampled`` mode."""
    max_samples: int = 300000
    """Most samples of one mesh set in the ``sampled`` mode."""
    seed: int = 0
    """Seed of the surface sampling."""
    fuse_voxel: float = 0.02
    """Voxel length of the depth fusion (m)."""
    depth_max: float = 8.0
    """Depth beyond this is not fused (m)."""
    fuse_scale: float = 0.5
    """Image scale of the depth frames that are fused (1 = full resolution)."""
    fuse_stride: int = 4
    """Fuse every n-th capture camera."""
    label_radius: float = 0.05
    """A fused point takes the instance of the nearest labelled point within this distance (m), else none."""


@dataclass(frozen=True)
class PointSet:
    """Points float64 [n, 3] (world, m), unit normals float64 [n, 3] or None, and a label per point
    int64 [n] (instance id; 0 = none) or None."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64] | None = None
    labels: NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return len(self.points)

    def labelled(self, keep: Any) -> PointSet:
        """The points whose label passes ``keep`` (a function of the label array); none without labels."""
        if self.labels is None:
            return self.select(np.zeros(len(self), bool))
        return self.select(keep(self.labels))

    def select(self, mask: NDArray[np.bool_]) -> PointSet:
        return PointSet(
            self.points[mask],
            None if self.normals is None else self.normals[mask],
            None if self.labels is None else self.labels[mask],
        )

    @staticmethod
    def concatenate(sets: Sequence[PointSet]) -> PointSet:
        sets = [s for s in sets if len(s)]
        if not sets:
            return PointSet(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64))
        normals = None if any(s.normals is None for s in sets) else np.concatenate([s.normals for s in sets])
        labels = None if any(s.labels is None for s in sets) else np.concatenate([s.labels for s in sets])
        return PointSet(np.concatenate([s.points for s in sets]), normals, labels)


def sample_surface(mesh: trimesh.Trimesh, n: int, seed: int = 0, label: int = 0) -> PointSet:
    """``n`` points drawn uniformly on the surface of ``mesh``, with face normals and ``label``."""
    if len(mesh.faces) == 0 or mesh.area <= 0 or n <= 0:
        return PointSet(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64))
    points, face = trimesh.sample.sample_surface(mesh, n, seed=seed)
    normals = np.asarray(mesh.face_normals, np.float64)[face]
    return PointSet(np.asarray(points, np.float64), normals, np.full(len(points), int(label), np.int64))


def sample_meshes(meshes: Mapping[int, trimesh.Trimesh], config: GeometryConfig) -> PointSet:
    """Area-proportional samples of labelled meshes (label = key), at most ``max_samples`` in all."""
    area = {k: float(m.area) for k, m in meshes.items() if len(m.faces)}
    total = sum(area.values())
    if total <= 0:
        return PointSet(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64))
    density = min(config.samples_per_m2, config.max_samples / total)
    return PointSet.concatenate(
        [
            sample_surface(meshes[k], max(config.min_samples, int(round(a * density))), config.seed + k % 9973, k)
            for k, a in sorted(area.items())
        ]
    )


def downsample(points: PointSet, voxel: float) -> PointSet:
    """One point per occupied ``voxel`` (the mean of its points, as Open3D's ``voxel_down_sample``, with
    the grid anchored at the minimum bound less half a voxel); normals are averaged and renormalised,
    labels take the most frequent label of the voxel."""
    if len(points) == 0 or voxel <= 0:
        return points
    pts = points.points
    cell = np.floor((pts - (pts.min(0) - voxel / 2)) / voxel).astype(np.int64)
    dims = cell.max(0) + 1
    key = (cell[:, 2] * dims[1] + cell[:, 1]) * dims[0] + cell[:, 0]
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    n = len(counts)

    def mean(values: NDArray) -> NDArray[np.float64]:
        out = np.zeros((n, values.shape[1]))
        for c in range(values.shape[1]):
            out[:, c] = np.bincount(inverse, weights=values[:, c], minlength=n)
        return out / counts[:, None]

    normals = None
    if points.normals is not None:
        normals = mean(points.normals)
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    labels = None
    if points.labels is not None:
        # most frequent label per voxel: count (voxel, label) pairs, keep each voxel's largest count
        lab_values, lab_index = np.unique(points.labels, return_inverse=True)
        pair, pair_counts = np.unique(inverse * len(lab_values) + lab_index, return_counts=True)
        voxel_of, label_of = pair // len(lab_values), pair % len(lab_values)
        order = np.lexsort((-pair_counts, voxel_of))
        first = np.concatenate([[True], np.diff(voxel_of[order]) != 0])
        labels = np.zeros(n, np.int64)
        labels[voxel_of[order][first]] = lab_values[label_of[order][first]]
    return PointSet(mean(pts), normals, labels)


def point_metrics(pred: PointSet, ref: PointSet, thresholds: Iterable[float] = (0.05, 0.10)) -> dict[str, Any]:
    """Accuracy, completion, Chamfer, precision / recall / F at each threshold, normal consistency and
    centre offset of two (already downsampled) point sets; None where a set is empty."""
    thresholds = tuple(thresholds)
    out: dict[str, Any] = {"points_pred": len(pred), "points_ref": len(ref)}
    keys = ["accuracy", "completion", "chamfer", "normal_consistency", "centre_offset"]
    for t in thresholds:
        keys += [f"precision@{_cm(t)}", f"recall@{_cm(t)}", f"fscore@{_cm(t)}"]
    if len(pred) == 0 or len(ref) == 0:
        return {**out, **{k: None for k in keys}}
    d_acc, i_acc = cKDTree(ref.points).query(pred.points, workers=-1)
    d_comp, i_comp = cKDTree(pred.points).query(ref.points, workers=-1)
    out["accuracy"] = float(d_acc.mean())
    out["completion"] = float(d_comp.mean())
    out["chamfer"] = (out["accuracy"] + out["completion"]) / 2
    for t in thresholds:
        p, r = float((d_acc < t).mean()), float((d_comp < t).mean())
        out[f"precision@{_cm(t)}"] = p
        out[f"recall@{_cm(t)}"] = r
        out[f"fscore@{_cm(t)}"] = 2 * p * r / (p + r) if p + r > 0 else 0.0
    if pred.normals is not None and ref.normals is not None:
        c_acc = np.abs(np.einsum("ij,ij->i", pred.normals, ref.normals[i_acc]))
        c_comp = np.abs(np.einsum("ij,ij->i", ref.normals, pred.normals[i_comp]))
        out["normal_consistency"] = float((c_acc.mean() + c_comp.mean()) / 2)
    else:
        out["normal_consistency"] = None
    centre = [0.5 * (s.points.min(0) + s.points.max(0)) for s in (pred, ref)]
    out["centre_offset"] = float(np.linalg.norm(centre[0] - centre[1]))
    return out


def _cm(t: float) -> str:
    return f"{round(t * 100):d}cm"


def scaled_camera(camera: Camera, scale: float) -> Camera:
    """``camera`` with its image scaled by ``scale`` (pixel centres kept consistent)."""
    if scale == 1:
        return camera
    w, h = max(1, int(round(camera.width * scale))), max(1, int(round(camera.height * scale)))
    K = np.array(camera.K, np.float64)
    sx, sy = w / camera.width, h / camera.height
    K[0, 0] *= sx
    K[0, 2] *= sx
    K[1, 1] *= sy
    K[1, 2] *= sy
    return Camera(K, camera.world_from_cam, w, h)


def backproject(depth: NDArray, camera: Camera, max_step: float = 0.05, labels: NDArray | None = None) -> PointSet:
    """World points [n, 3] of the valid pixels of a depth map float32 [H, W] (metres along camera z,
    0 = invalid) with unit normals facing the camera from the depth gradients; pixels whose right or lower
    neighbour is invalid or more than ``max_step`` times their depth away (a depth edge) are left out.
    labels: optional int [H, W] per-pixel label (e.g. the rendered instance id) carried to the points."""
    depth = np.asarray(depth, np.float32)
    h, w = depth.shape
    K = camera.K
    u = ((np.arange(w) + 0.5 - K[0, 2]) / K[0, 0]).astype(np.float32)
    v = ((np.arange(h) + 0.5 - K[1, 2]) / K[1, 1]).astype(np.float32)
    d0, dr, dd = depth[:-1, :-1], depth[:-1, 1:], depth[1:, :-1]
    ok = (d0 > 0) & (dr > 0) & (dd > 0) & (np.abs(dr - d0) < max_step * d0) & (np.abs(dd - d0) < max_step * d0)
    rows, cols = np.nonzero(ok)
    z, zr, zd = d0[rows, cols], dr[rows, cols], dd[rows, cols]
    x, y = u[cols] * z, v[rows] * z
    # tangents to the right and downwards neighbours, and their cross product
    ax, ay, az = u[cols + 1] * zr - x, v[rows] * zr - y, zr - z
    bx, by, bz = u[cols] * zd - x, v[rows + 1] * zd - y, zd - z
    normal = np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], 1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    pts = np.stack([x, y, z], 1)
    normal *= np.where(np.einsum("ij,ij->i", normal, pts) > 0, -1.0, 1.0).astype(np.float32)[:, None]
    rot, t = camera.world_from_cam[:3, :3], camera.world_from_cam[:3, 3]
    lab = None if labels is None else np.asarray(labels)[:-1, :-1][rows, cols].astype(np.int64)
    return PointSet(pts @ rot.T + t, normal @ rot.T, lab)


FUSE_CHUNK_POINTS = 2_000_000
"""Back-projected points gathered before they are folded into the fusion's voxel sums (about 110 MB with
normals and labels): the fusion holds this plus one entry per occupied voxel, whatever the frame count."""
_CELL_BITS = 21
"""Bits per axis of a packed voxel key (three axes in an int64): cells within +-2^20 voxels of the origin."""


class VoxelSums:
    """Running per-voxel sums of a stream of points on a grid of ``voxel`` (m) whose cell corners lie at
    ``origin`` + k ``voxel`` (voxel (i, j, k) holds the points with floor((p - origin) / voxel) = (i, j, k)):
    the mean point and normal of each voxel and, per voxel, how often each label was seen. Its memory
    grows with the occupied voxels, not with the points added.

    origin: float64 [3] world point (m); ``downsample`` anchors its grid at the points' minimum less half a
    voxel, so a stream given that origin fuses to exactly ``downsample`` of all its points at once.
    ``add`` takes one chunk of points; ``result`` is the fused set: one point per occupied voxel (the mean
    of its points, ordered by z, then y, then x cell, as ``downsample``), normals averaged and renormalised
    (None when a chunk had none), the voxel's most frequent label (the smallest on a tie; None when a chunk
    had none).
    """

    def __init__(self, voxel: float, origin: NDArray[np.float64] | None = None):
        if not voxel > 0:
            raise ValueError(f"voxel {voxel!r}: the fusion's voxel length (GeometryConfig.fuse_voxel) must be > 0 m")
        self.voxel = float(voxel)
        self.origin = np.zeros(3) if origin is None else np.asarray(origin, np.float64).reshape(3)
        self.keys = np.zeros(0, np.int64)  # [v] packed voxel keys, sorted
        self.sums = np.zeros((0, 3))  # [v, 3] sum of the points (m)
        self.normal_sums: NDArray[np.float64] | None = np.zeros((0, 3))  # [v, 3] sum of the normals
        self.counts = np.zeros(0, np.int64)  # [v] points per voxel
        # label counts per (voxel key, label), sorted by voxel then label; None once a chunk had no labels
        self.pairs: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]] | None = (
            np.zeros(0, np.int64),
            np.zeros(0, np.int64),
            np.zeros(0, np.int64),
        )

    def _pack(self, points: NDArray[np.float64]) -> NDArray[np.int64]:
        cell = np.floor((points - self.origin) / self.voxel).astype(np.int64)
        half = 1 << (_CELL_BITS - 1)
        if len(cell) and (cell.min() < -half or cell.max() >= half):
            reach = half * self.voxel
            raise ValueError(
                f"fused points reach {np.abs(points - self.origin).max():.1f} m from the grid's origin; a "
                f"{self.voxel:g} m fusion grid holds points within {reach:.0f} m of it (check the capture's poses "
                "and depth units, or raise GeometryConfig.fuse_voxel)"
            )
        cell += half  # z-major keys: sorted like downsample's voxels
        return (cell[:, 2] << (2 * _CELL_BITS)) | (cell[:, 1] << _CELL_BITS) | cell[:, 0]

    def add(self, chunk: PointSet) -> None:
        """Fold the points [n, 3] of ``chunk`` (with their normals and labels, when it has them) into the sums."""
        if len(chunk) == 0:
            return
        key = self._pack(np.asarray(chunk.points, np.float64))
        keys, inverse = np.unique(np.concatenate([self.keys, key]), return_inverse=True)
        old, new = inverse[: len(self.keys)], inverse[len(self.keys) :]
        n = len(keys)

        def fold(before: NDArray[np.float64], values: NDArray) -> NDArray[np.float64]:
            out = np.zeros((n, 3))
            out[old] = before
            for c in range(3):
                out[:, c] += np.bincount(new, weights=values[:, c], minlength=n)
            return out

        self.sums = fold(self.sums, chunk.points)
        self.normal_sums = (
            None if chunk.normals is None or self.normal_sums is None else fold(self.normal_sums, chunk.normals)
        )
        counts = np.zeros(n, np.int64)
        counts[old] = self.counts
        self.counts = counts + np.bincount(new, minlength=n)
        self.keys = keys
        if chunk.labels is None or self.pairs is None:
            self.pairs = None
            return
        vox = np.concatenate([self.pairs[0], key])
        lab = np.concatenate([self.pairs[1], np.asarray(chunk.labels, np.int64)])
        cnt = np.concatenate([self.pairs[2], np.ones(len(key), np.int64)])
        order = np.lexsort((lab, vox))
        vox, lab, cnt = vox[order], lab[order], cnt[order]
        start = np.flatnonzero(np.concatenate([[True], (np.diff(vox) != 0) | (np.diff(lab) != 0)]))
        self.pairs = (vox[start], lab[start], np.add.reduceat(cnt, start))

    def result(self) -> PointSet:
        """The fused points [v, 3] (see the class doc); an empty set when nothing was added."""
        if len(self.keys) == 0:
            return PointSet.concatenate([])
        normals = None
        if self.normal_sums is not None:
            normals = self.normal_sums / self.counts[:, None]
            normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        labels = None
        if self.pairs is not None:
            vox, lab, cnt = self.pairs
            order = np.lexsort((-cnt, vox))  # stable: on a tie the smaller label (pairs are sorted by label)
            first = order[np.concatenate([[True], np.diff(vox[order]) != 0])]
            labels = lab[first]  # one per voxel, in key order as self.keys
        return PointSet(self.sums / self.counts[:, None], normals, labels)


def fuse_depth(frames: Callable[[], Iterable[tuple]], config: GeometryConfig) -> PointSet:
    """Fusion of depth maps float32 [H, W] (metres along camera z, 0 = invalid) seen by their cameras
    (``frames()`` yields ``(depth, camera)`` or ``(depth, camera, labels [H, W])``; labelled points keep the
    voxel's majority): every valid pixel is back-projected (``backproject``, up to ``depth_max``) and the
    points of each ``fuse_voxel`` voxel are averaged, normals too. Only surfaces some camera saw get
    points. The result is ``downsample(all points, fuse_voxel)``.

    Memory is bounded whatever the frame count: ``frames`` is called twice (a first pass finds the
    points' minimum, where ``downsample`` anchors its grid), and the second pass folds the points into
    ``VoxelSums`` every ``FUSE_CHUNK_POINTS`` points instead of holding them all.

    (A TSDF would be the usual choice; with open3d 0.20.0 the legacy ``ScalableTSDFVolume`` integrates
    nothing and the dense ``UniformTSDFVolume`` takes 16 s to allocate one room at 2 cm. The tensor
    ``VoxelBlockGrid`` works, see ``rescene_core.segment.geometric.fusion.tsdf_mesh``, and is not used here yet.)"""

    def points() -> Iterator[PointSet]:
        for depth, camera, *labels in frames():
            depth = np.where(np.asarray(depth) <= config.depth_max, depth, 0.0)
            pts = backproject(depth, camera, labels=labels[0] if labels else None)
            if len(pts):
                yield pts

    low = np.full(3, np.inf)
    for pts in points():
        low = np.minimum(low, pts.points.min(0))
    if not np.isfinite(low).all():
        return PointSet.concatenate([])
    fused = VoxelSums(config.fuse_voxel, origin=low - config.fuse_voxel / 2)
    pending: list[PointSet] = []
    held = 0
    for pts in points():
        pending.append(pts)
        held += len(pts)
        if held >= FUSE_CHUNK_POINTS:
            fused.add(PointSet.concatenate(pending))
            pending, held = [], 0
    fused.add(PointSet.concatenate(pending))
    return fused.result()


def rendered_depths(
    meshes: Mapping[int, trimesh.Trimesh], cameras: Sequence[Camera], config: GeometryConfig
) -> Iterable[tuple[NDArray[np.float32], Camera]]:
    """(depth, camera, mesh key per pixel) of ``meshes`` rendered along ``cameras`` (scaled by ``fuse_scale``)
    with the project's ray caster."""

    render = [
        RenderMesh.uniform(k if k != 0 else -999999, m.vertices, m.faces, (0.5, 0.5, 0.5))
        for k, m in meshes.items()
        if len(m.faces)
    ]
    caster = RayCaster(render)
    for camera in cameras:
        cam = scaled_camera(camera, config.fuse_scale)
        hits = caster.cast_camera(cam)
        yield hits.depth, cam, np.where(hits.ids == -999999, 0, hits.ids)


def label_points(points: PointSet, labelled: PointSet, radius: float) -> PointSet:
    """``points`` with the label of their nearest point in ``labelled`` when within ``radius``, else 0."""
    if len(points) == 0 or len(labelled) == 0 or labelled.labels is None:
        return PointSet(points.points, points.normals, np.zeros(len(points), np.int64))
    d, i = cKDTree(labelled.points).query(points.points, workers=-1)
    return PointSet(points.points, points.normals, np.where(d <= radius, labelled.labels[i], 0).astype(np.int64))


def refuse(meshes: Mapping[int, trimesh.Trimesh], cameras: Sequence[Camera], config: GeometryConfig) -> PointSet:
    """The ``refused`` point set of labelled meshes: depth rendered along ``cameras`` and fused; each
    fused point takes the key of the mesh its pixels hit (the voxel's majority)."""
    return fuse_depth(lambda: rendered_depths(meshes, cameras, config), config)


def compare(pred: PointSet, ref: PointSet, config: GeometryConfig) -> dict[str, Any]:
    """``point_metrics`` of the two sets after voxel downsampling."""
    return point_metrics(downsample(pred, config.voxel_size), downsample(ref, config.voxel_size), config.thresholds)


def per_label(
    pred: PointSet, ref: PointSet, pairs: Mapping[int, Iterable[int]], config: GeometryConfig
) -> dict[int, dict[str, Any]]:
    """Metrics per predicted label: pairs maps a predicted label to the reference labels it is compared
    with (both sets labelled; each is downsampled once)."""
    pred_d, ref_d = downsample(pred, config.voxel_size), downsample(ref, config.voxel_size)
    out = {}
    for p, refs in pairs.items():
        refs = list(refs)
        out[int(p)] = point_metrics(
            pred_d.labelled(lambda lab, p=p: lab == p),
            ref_d.labelled(lambda lab, refs=refs: np.isin(lab, refs)),
            config.thresholds,
        )
    return out


def capture_cameras(capture: Any, frames: Sequence[int] | None, stride: int) -> list[Camera]:
    """The capture's cameras (all frames or ``frames``), every ``stride``-th."""
    idx = list(range(capture.num_frames)) if frames is None else list(frames)
    return [capture.camera(t) for t in idx[:: max(1, stride)]]


def sensor_reference(capture: Any, config: GeometryConfig) -> PointSet:
    """Fusion (``fuse_depth``) of the capture's own depth frames (every ``fuse_stride``-th, at ``fuse_scale``), each
    fused point labelled with the capture instance of the nearest instance point (0 = none)."""

    if capture.depth is None:
        raise ValueError(f"{capture.path} has no frames/depth")

    def frames():
        for t in range(0, capture.num_frames, max(1, config.fuse_stride)):
            cam = scaled_camera(capture.camera(t), config.fuse_scale)
            depth = np.asarray(capture.depth[t], np.float32)
            if (cam.width, cam.height) != (depth.shape[1], depth.shape[0]):
                # nearest keeps depth edges sharp (no mixed foreground/background depths)
                depth = np.asarray(Image.fromarray(depth).resize((cam.width, cam.height), Image.NEAREST))
            yield depth, cam

    fused = fuse_depth(frames, config)
    pts, ids = capture.all_points()
    labelled = PointSet(np.asarray(pts, np.float64), None, np.asarray(ids, np.int64))
    if len(labelled) > config.max_samples:
        keep = np.random.default_rng(config.seed).choice(len(labelled), config.max_samples, replace=False)
        labelled = labelled.select(np.sort(keep))
    return label_points(fused, labelled, config.label_radius)


def _mean_rows(rows: list[dict[str, Any]], key: str) -> float | None:
    vals = [r[key] for r in rows if r.get(key) is not None]
    return float(np.mean(vals)) if vals else None


def geometry_metrics(
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    capture: Any,
    gt: Any | None,
    config: GeometryConfig | None = None,
) -> dict[str, Any]:
    """Geometry metrics of a placed scene: against ground truth (``gt``, when given) and against the
    sensor (when the capture has depth), each ``sampled`` and ``refused``, scene-level and per object.

    placed: instance id -> (label, world-frame mesh) of every placed object.
    shell: name -> world-frame mesh of the exported room shell (floor slab, walls); they occlude in the
        re-fusion and are part of the 'all surfaces' comparison against the sensor.
    capture: an opened ``Capture`` (cameras, depth, instance points). gt: its ``GroundTruth`` or None.
    Returns plain JSON types; a comparison that cannot be made is listed in ``not_computed``.
    """
    config = config or GeometryConfig()
    out: dict[str, Any] = {"protocol": config.model_dump(mode="json"), "not_computed": {}}
    if not placed:
        out["not_computed"]["all"] = "the run placed no object"
        return out
    pred_meshes = {int(i): m for i, (_, m) in placed.items()}
    shell_keyed = {-(k + 1): m for k, (_, m) in enumerate(sorted(shell.items()))}
    labels = {int(i): lab for i, (lab, _) in placed.items()}
    cameras = capture_cameras(capture, None, config.fuse_stride)
    pred_sampled = sample_meshes(pred_meshes, config)
    pred_refused = refuse({**pred_meshes, **shell_keyed}, cameras, config)
    out["cameras_fused"] = len(cameras)

    if gt is None:
        out["not_computed"]["ground_truth"] = "the capture has no ground truth (gt/ group)"
    else:
        obj_of = gt.object_of_instance()
        gt_meshes = {int(o.object_id): gt.world_mesh(o.object_id) for o in gt.objects}
        if not gt_meshes:
            out["not_computed"]["ground_truth"] = "the ground truth has no objects"
        else:
            gt_shell = {-(k + 1): m for k, (_, m) in enumerate(sorted(shell_meshes(gt.shell, ExportConfig()).items()))}
            gt_sampled = sample_meshes(gt_meshes, config)
            gt_refused = refuse({**gt_meshes, **gt_shell}, cameras, config)
            pred_obj = pred_refused.labelled(lambda lab: lab > 0)
            gt_obj = gt_refused.labelled(lambda lab: lab > 0)
            pairs = {i: [obj_of[i]] for i in pred_meshes if i in obj_of}
            refused_rows = per_label(pred_obj, gt_obj, pairs, config)
            sampled_rows = per_label(pred_sampled, gt_sampled, pairs, config)
            rows = []
            for i in sorted(pred_meshes):
                row: dict[str, Any] = {"instance": i, "label": labels[i], "object_id": obj_of.get(i)}
                if i in obj_of:
                    row["sampled"] = sampled_rows[i]
                    row["refused"] = refused_rows[i]
                rows.append(row)
            out["ground_truth"] = {
                "sampled": compare(pred_sampled, gt_sampled, config),
                "refused": compare(pred_obj, gt_obj, config),
                "per_object": rows,
                "per_object_mean": {
                    mode: {
                        k: _mean_rows([r[mode] for r in rows if mode in r], k)
                        for k in ("chamfer", "fscore@5cm", "normal_consistency")
                    }
                    for mode in ("sampled", "refused")
                },
            }

    if capture.depth is None:
        out["not_computed"]["sensor"] = "the capture has no depth (frames/depth)"
    else:
        sensor = sensor_reference(capture, config)
        objects = {int(i.id) for i in capture.object_instances}
        ref_obj = sensor.labelled(lambda lab: np.isin(lab, list(objects)))
        pred_obj = pred_refused.labelled(lambda lab: lab > 0)
        rows_by = per_label(pred_obj, ref_obj, {i: [i] for i in pred_meshes}, config)
        rows = [{"instance": i, "label": labels[i], "refused": rows_by[i]} for i in sorted(pred_meshes)]
        out["sensor"] = {
            "reference": (
                f"fusion of the capture's own depth (back-projected, averaged per {config.fuse_voxel} m voxel; "
                f"every {config.fuse_stride} frame(s) at scale {config.fuse_scale})"
            ),
            "objects_sampled": compare(pred_sampled, ref_obj, config),
            "objects_refused": compare(pred_obj, ref_obj, config),
            "all_refused": compare(pred_refused, sensor, config),
            "per_object": rows,
        }
    return out


__all__ = [
    "GeometryConfig",
    "PointSet",
    "capture_cameras",
    "compare",
    "geometry_metrics",
    "downsample",
    "backproject",
    "fuse_depth",
    "FUSE_CHUNK_POINTS",
    "VoxelSums",
    "label_points",
    "per_label",
    "point_metrics",
    "refuse",
    "rendered_depths",
    "sample_meshes",
    "sample_surface",
    "scaled_camera",
    "sensor_reference",
]
