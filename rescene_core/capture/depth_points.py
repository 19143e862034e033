"""Instance point clouds from depth: back-project masked depth, fuse per instance (voxel downsample and
statistical outlier removal in Open3D).

A real panoptic output is least reliable along mask boundaries, exactly where depth jumps from the
object to what is behind it; a boundary pixel would put a point of the wall into the chair's cloud. So
each mask is eroded by a few pixels and pixels at depth edges (a relative jump to a neighbour above a
threshold) are left out before back-projection.

Memory does not grow with the scan. Both fusions read the frames one at a time (numpy arrays or frames
on disk, ``capture.format.FrameData``) and append the back-projected points to a file per cloud (each
instance's, or the scene's) in a temporary directory every ``SPILL_FRAMES`` frames, keeping each cloud's
count and lowest corner. Each cloud is then thinned on its own:

- up to ``EXACT_POINTS`` points, read at once into Open3D's ``voxel_down_sample``, as it always was;
- beyond, streamed from its file ``FOLD_POINTS`` at a time into per-voxel sums (``VoxelMeans``) on the grid
  ``voxel_down_sample`` uses (anchored half a voxel below the cloud's lowest corner), so the voxels and
  their mean points and colours are Open3D's (to float rounding); only their order differs (sorted by z,
  y, x cell instead of Open3D's hash order), which moves the evenly spaced subsample of a cloud beyond
  ``max_points_per_instance`` and the draws of a RANSAC on the scene cloud.

Every cloud of a 120-frame 640x480 scan stays under ``EXACT_POINTS``: its capture is the one fusing
everything at once gave.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict
from scipy import ndimage


class DepthPointsConfig(BaseModel):
    """Per-instance fusion of masked depth. Lengths in metres."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    stride: int = 2
    """Pixel stride of the back-projection."""
    erode_px: int = 2
    """Masks shrink by this many pixels before back-projection (boundary labels are unreliable)."""
    depth_edge_ratio: float = 0.05
    """A pixel whose depth differs from a 4-neighbour by more than this fraction of its depth is an edge."""
    object_voxel: float = 0.01
    """Voxel size of an object's fused cloud (m)."""
    structure_voxel: float = 0.05
    """Voxel size of floor, wall and ceiling clouds (m)."""
    outlier_neighbors: int = 20
    """Neighbours of the statistical outlier test."""
    outlier_std_ratio: float = 2.0
    """Points further than mean + ratio * std of the neighbour distances are dropped."""
    max_points_per_instance: int = 12000
    """Largest cloud kept per instance (evenly subsampled, deterministic)."""
    min_points: int = 20
    """Instances with fewer fused points get no cloud."""


SPILL_FRAMES = 32
"""Frames whose back-projected points are kept in memory before they go to the spill files."""
EXACT_POINTS = 4_000_000
"""A cloud of at most this many back-projected points is thinned at once by Open3D (about 0.45 GB at its
peak); a larger one is streamed through ``VoxelMeans``."""
FOLD_POINTS = 2_000_000
"""Points read from a spill file at a time when a cloud is streamed."""
_CELL_BITS = 21


class VoxelMeans:
    """Running per-voxel sums of a stream of points (and colours) on a grid of ``voxel`` (m) whose cells
    start at ``origin`` + k ``voxel``: voxel (i, j, k) holds the points with floor((p - origin) / voxel) =
    (i, j, k), as Open3D's ``voxel_down_sample`` with origin = the points' minimum - voxel / 2. Memory grows
    with the occupied voxels, not with the points added.

    origin: float64 [3] (m). ``add(points [n, 3] m, colors [n, 3] in [0, 1] or None)``; ``result()``: the
    mean point [v, 3] of each occupied voxel and its mean colour [v, 3] (None when no colours were added),
    ordered by z, then y, then x cell."""

    def __init__(self, voxel: float, origin: NDArray[np.float64]):
        if not voxel > 0:
            raise ValueError(f"voxel {voxel!r}: the thinning voxel length must be > 0 m")
        self.voxel = float(voxel)
        self.origin = np.asarray(origin, np.float64).reshape(3)
        self.keys = np.zeros(0, np.int64)  # [v] packed cell keys, sorted
        self.sums = np.zeros((0, 3))  # [v, 3] sum of the points (m)
        self.color_sums: NDArray[np.float64] | None = None  # [v, 3] sum of the colours
        self.counts = np.zeros(0, np.int64)  # [v] points per voxel

    def add(self, points: NDArray, colors: NDArray | None = None) -> None:
        if not len(points):
            return
        pts = np.asarray(points, np.float64)
        cell = np.floor((pts - self.origin) / self.voxel).astype(np.int64)
        half = 1 << (_CELL_BITS - 1)
        if cell.min() < -half or cell.max() >= half:
            raise ValueError(
                f"points reach {np.abs(pts - self.origin).max():.1f} m from the grid's origin; a {self.voxel:g} m "
                f"grid holds points within {half * self.voxel:.0f} m of it (check the poses and the depth units)"
            )
        cell += half
        key = (cell[:, 2] << (2 * _CELL_BITS)) | (cell[:, 1] << _CELL_BITS) | cell[:, 0]
        keys, inverse = np.unique(np.concatenate([self.keys, key]), return_inverse=True)
        old, new = inverse[: len(self.keys)], inverse[len(self.keys) :]
        n = len(keys)

        def fold(before: NDArray[np.float64] | None, values: NDArray[np.float64]) -> NDArray[np.float64]:
            out = np.zeros((n, 3))
            if before is not None:
                out[old] = before
            for c in range(3):
                out[:, c] += np.bincount(new, weights=values[:, c], minlength=n)
            return out

        self.sums = fold(self.sums, pts)
        if colors is not None:
            self.color_sums = fold(self.color_sums, np.asarray(colors, np.float64))
        counts = np.zeros(n, np.int64)
        counts[old] = self.counts
        self.counts = counts + np.bincount(new, minlength=n)
        self.keys = keys

    def result(self) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        count = np.maximum(self.counts, 1)[:, None]
        return self.sums / count, None if self.color_sums is None else self.color_sums / count


class _Spill:
    """Per-cloud files of float32 points [n, 3] (and uint8 colours [n, 3]) in ``folder``, with each cloud's
    point count and lowest corner; ``thin`` reads one cloud back and voxel-thins it."""

    def __init__(self, folder: Path, colors: bool):
        self.folder = folder
        self.colors = colors
        self.count: dict[int, int] = {}
        self.low: dict[int, NDArray[np.float32]] = {}
        self.pending: dict[int, list[tuple[NDArray, NDArray | None]]] = {}

    def add(self, key: int, points: NDArray, colors: NDArray | None = None) -> None:
        if len(points):
            self.pending.setdefault(key, []).append((points, colors))

    def flush(self) -> None:
        for key, parts in self.pending.items():
            with open(self.folder / f"{key}.xyz", "ab") as fp:
                for p, _ in parts:
                    p = np.ascontiguousarray(p, np.float32)
                    fp.write(p.tobytes())
                    self.count[key] = self.count.get(key, 0) + len(p)
                    low = p.min(axis=0)
                    self.low[key] = np.minimum(self.low[key], low) if key in self.low else low
            if self.colors:
                with open(self.folder / f"{key}.rgb", "ab") as fc:
                    for _, c in parts:
                        fc.write(np.ascontiguousarray(c, np.uint8).tobytes())
        self.pending.clear()

    def thin(self, key: int, voxel: float) -> Any:
        """The cloud ``key`` thinned at ``voxel`` (m), an Open3D point cloud (colours in [0, 1] when it was
        spilled with them), as the module doc says; its files are deleted."""
        import open3d as o3d

        xyz, rgb = self.folder / f"{key}.xyz", self.folder / f"{key}.rgb"
        n = self.count.get(key, 0)
        if n <= EXACT_POINTS:
            pcd = o3d.geometry.PointCloud(
                o3d.utility.Vector3dVector(np.fromfile(xyz, np.float32).reshape(-1, 3).astype(np.float64))
            )
            if self.colors:
                col = np.fromfile(rgb, np.uint8).reshape(-1, 3).astype(np.float64) / 255.0
                pcd.colors = o3d.utility.Vector3dVector(col)
            out = pcd.voxel_down_sample(voxel)
        else:
            sums = VoxelMeans(voxel, self.low[key].astype(np.float64) - voxel * 0.5)
            for a in range(0, n, FOLD_POINTS):
                m = min(FOLD_POINTS, n - a)
                p = np.fromfile(xyz, np.float32, count=3 * m, offset=12 * a).reshape(-1, 3)
                c = None
                if self.colors:
                    c = np.fromfile(rgb, np.uint8, count=3 * m, offset=3 * a).reshape(-1, 3).astype(np.float64) / 255.0
                sums.add(p, c)
            means, colors = sums.result()
            out = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(means))
            if colors is not None:
                out.colors = o3d.utility.Vector3dVector(colors)
        xyz.unlink(missing_ok=True)
        rgb.unlink(missing_ok=True)
        return out


READ_FRAMES = 16
"""Frames read at a time from arrays on disk (a zarr read of several chunks decodes them concurrently)."""


def _frames(*arrays: Any) -> Any:
    """(t, frame t of each array as numpy) for t = 0 .. T - 1, reading ``READ_FRAMES`` frames at a time."""
    n = int(arrays[0].shape[0])
    for a in range(0, n, READ_FRAMES):
        b = min(a + READ_FRAMES, n)
        slabs = [np.asarray(x[a:b]) for x in arrays]
        for k in range(b - a):
            yield (a + k, *(s[k] for s in slabs))


def depth_edges(depth: NDArray[np.float32], ratio: float) -> NDArray[np.bool_]:
    """Pixels [H, W] next to a relative depth jump above ``ratio`` (or next to invalid depth)."""
    d = depth.astype(np.float32)
    edge = np.zeros(d.shape, bool)
    for a, b, sl_a, sl_b in (
        (d[:, 1:], d[:, :-1], (slice(None), slice(1, None)), (slice(None), slice(None, -1))),
        (d[1:], d[:-1], (slice(1, None), slice(None)), (slice(None, -1), slice(None))),
    ):
        jump = np.abs(a - b) > ratio * np.maximum(np.minimum(a, b), 1e-6)
        jump |= (a > 0) != (b > 0)
        edge[sl_a] |= jump
        edge[sl_b] |= jump
    return edge


def backproject(
    depth: NDArray[np.float32], K: NDArray, world_from_cam: NDArray, select: NDArray[np.bool_], stride: int = 1
) -> tuple[NDArray[np.float32], NDArray[np.int64], NDArray[np.int64]]:
    """World points [n, 3] of the selected pixels with valid depth (every ``stride``-th pixel), and their
    rows and columns. Pixel u's ray passes through u + 0.5 (the project's renderer convention)."""
    s = max(1, int(stride))
    d = depth[::s, ::s]
    vs, us = np.nonzero((d > 0) & select[::s, ::s])
    z = d[vs, us].astype(np.float64)
    vs, us = vs * s, us * s
    x = (us + 0.5 - K[0, 2]) / K[0, 0] * z
    y = (vs + 0.5 - K[1, 2]) / K[1, 1] * z
    pts = np.stack([x, y, z], axis=1) @ np.asarray(world_from_cam)[:3, :3].T + np.asarray(world_from_cam)[:3, 3]
    return pts.astype(np.float32), vs, us


def scene_points(
    depth: Any,
    K: NDArray,
    world_from_cam: NDArray,
    stride: int = 4,
    voxel: float = 0.03,
    spill_dir: str | Path | None = None,
) -> NDArray[np.float64]:
    """All frames' valid depth fused into one voxel-thinned cloud [n, 3] (for alignment and planes).

    depth: [T, H, W] float32 metres (numpy or ``FrameData``, read a frame at a time); K [T, 3, 3];
    world_from_cam [T, 4, 4]. Every ``stride``-th pixel's point goes to a spill file (0.23 MB a 640x480
    frame at stride 4) and is thinned as the module doc says (beyond ``EXACT_POINTS``, about 200 such
    frames, streamed). spill_dir: where the temporary file goes (default: the system's temporary directory)."""
    with tempfile.TemporaryDirectory(prefix="rescene-points-", dir=spill_dir) as folder:
        spill = _Spill(Path(folder), colors=False)
        for t, d in _frames(depth):
            if t % SPILL_FRAMES == 0:
                spill.flush()
            p, _, _ = backproject(d, K[t], world_from_cam[t], np.ones(d.shape, bool), stride)
            spill.add(0, p)
        spill.flush()
        if not spill.count.get(0):
            return np.zeros((0, 3))
        return np.asarray(spill.thin(0, voxel).points)


def instance_points(
    depth: Any,
    masks: Any,
    rgb: Any,
    K: NDArray,
    world_from_cam: NDArray,
    structural: set[int],
    config: DepthPointsConfig | None = None,
    spill_dir: str | Path | None = None,
) -> tuple[dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]], dict[str, int]]:
    """Per-instance fused clouds {id: (points float32 [n, 3] world m, colours uint8 [n, 3])} and counts
    of what was left out ({"eroded": pixels, "depth_edges": pixels, "outliers": points}).

    depth, masks: [T, H, W]; rgb [T, H, W, 3] (numpy or ``FrameData``, read a frame at a time);
    K [T, 3, 3]; world_from_cam [T, 4, 4] (OpenCV axes). structural: ids fused at the coarser structure voxel.
    spill_dir: where the temporary per-instance point files go (default: the system's temporary directory).
    """
    with tempfile.TemporaryDirectory(prefix="rescene-points-", dir=spill_dir) as folder:
        return _instance_points(
            depth, masks, rgb, K, world_from_cam, structural, config or DepthPointsConfig(), Path(folder)
        )


def _instance_points(
    depth: Any,
    masks: Any,
    rgb: Any,
    K: NDArray,
    world_from_cam: NDArray,
    structural: set[int],
    cfg: DepthPointsConfig,
    folder: Path,
) -> tuple[dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]], dict[str, int]]:
    spill = _Spill(folder, colors=True)
    stats = {"eroded_pixels": 0, "depth_edge_pixels": 0, "outlier_points": 0}
    r = max(0, int(cfg.erode_px))
    for t, m, d, image in _frames(masks, depth, rgb):
        if t % SPILL_FRAMES == 0:
            spill.flush()
        ids = np.unique(m)
        ids = ids[ids > 0]
        if not len(ids):
            continue
        keep = m > 0
        if r > 0:
            # a pixel survives when its (2r+1)^2 neighbourhood carries its own label only
            lo = ndimage.minimum_filter(m, size=2 * r + 1, mode="nearest")
            hi = ndimage.maximum_filter(m, size=2 * r + 1, mode="nearest")
            inner = keep & (lo == m) & (hi == m)
            stats["eroded_pixels"] += int((keep & ~inner).sum())
            keep = inner
        edges = depth_edges(d, cfg.depth_edge_ratio) & keep
        stats["depth_edge_pixels"] += int(edges.sum())
        keep &= ~edges
        pts, vs, us = backproject(d, K[t], world_from_cam[t], keep, cfg.stride)
        if not len(pts):
            continue
        lab = m[vs, us]
        col = image[vs, us]
        order = np.argsort(lab, kind="stable")
        lab, pts, col = lab[order], pts[order], col[order]
        cuts = np.flatnonzero(np.diff(lab)) + 1
        for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(lab)]])):
            spill.add(int(lab[a]), pts[a:b], col[a:b])
    spill.flush()
    clouds: dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]] = {}
    for iid in sorted(spill.count):  # one instance at a time
        pcd = spill.thin(iid, cfg.structure_voxel if iid in structural else cfg.object_voxel)
        if len(pcd.points) > cfg.outlier_neighbors:
            n0 = len(pcd.points)
            pcd, _ = pcd.remove_statistical_outlier(cfg.outlier_neighbors, cfg.outlier_std_ratio)
            stats["outlier_points"] += n0 - len(pcd.points)
        p = np.asarray(pcd.points, np.float32)
        c = np.clip(np.round(np.asarray(pcd.colors) * 255), 0, 255).astype(np.uint8)
        if len(p) < cfg.min_points:
            continue
        if len(p) > cfg.max_points_per_instance:
            sel = np.linspace(0, len(p) - 1, cfg.max_points_per_instance).round().astype(np.int64)
            p, c = p[sel], c[sel]
        clouds[iid] = (p, c)
    return clouds, stats
