"""Instance point clouds from depth: back-project masked depth, fuse per instance (voxel downsample and
statistical outlier removal in Open3D).

A real panoptic output is least reliable along mask boundaries, exactly where depth jumps from the
object to what is behind it; a boundary pixel would put a point of the wall into the chair's cloud. So
each mask is eroded by a few pixels and pixels at depth edges (a relative jump to a neighbour above a
threshold) are left out before back-projection.

Both fusions read the frames one at a time (numpy arrays or frames on disk, ``capture.format.FrameData``).
``instance_points`` appends each instance's back-projected points to its own file in a temporary
directory every ``SPILL_FRAMES`` frames and fuses one instance at a time, so it holds the largest
instance's points, not every instance's; the fused clouds are those of fusing all points at once (same
points, same order).
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
"""Frames whose back-projected instance points are kept in memory before they go to the spill files."""


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
    depth: Any, K: NDArray, world_from_cam: NDArray, stride: int = 4, voxel: float = 0.03
) -> NDArray[np.float64]:
    """All frames' valid depth fused into one voxel-thinned cloud [n, 3] (for alignment and planes).

    depth: [T, H, W] float32 metres (numpy or ``FrameData``, read a frame at a time); K [T, 3, 3];
    world_from_cam [T, 4, 4]. Holds every ``stride``-th pixel's point of every frame (0.23 MB a 640x480
    frame at stride 4) until the voxel pass."""
    import open3d as o3d

    chunks = []
    for t in range(int(depth.shape[0])):
        d = np.asarray(depth[t])
        p, _, _ = backproject(d, K[t], world_from_cam[t], np.ones(d.shape, bool), stride)
        chunks.append(p)
    pts = np.concatenate(chunks, dtype=np.float64) if chunks else np.zeros((0, 3))
    del chunks
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    del pts
    return np.asarray(pcd.voxel_down_sample(voxel).points)


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
    with tempfile.TemporaryDirectory(prefix="rescene-points-", dir=spill_dir) as spill:
        return _instance_points(
            depth, masks, rgb, K, world_from_cam, structural, config or DepthPointsConfig(), Path(spill)
        )


def _instance_points(
    depth: Any,
    masks: Any,
    rgb: Any,
    K: NDArray,
    world_from_cam: NDArray,
    structural: set[int],
    cfg: DepthPointsConfig,
    spill: Path,
) -> tuple[dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]], dict[str, int]]:
    import open3d as o3d

    per_id: dict[int, list[tuple[NDArray, NDArray]]] = {}  # points of the frames since the last spill
    spilled: set[int] = set()

    def flush() -> None:
        for iid, parts in per_id.items():
            with open(spill / f"{iid}.xyz", "ab") as fp, open(spill / f"{iid}.rgb", "ab") as fc:
                for p, c in parts:
                    fp.write(np.ascontiguousarray(p, np.float32).tobytes())
                    fc.write(np.ascontiguousarray(c, np.uint8).tobytes())
            spilled.add(iid)
        per_id.clear()

    stats = {"eroded_pixels": 0, "depth_edge_pixels": 0, "outlier_points": 0}
    r = max(0, int(cfg.erode_px))
    for t in range(int(masks.shape[0])):
        if t % SPILL_FRAMES == 0:
            flush()
        m = np.asarray(masks[t])
        d = np.asarray(depth[t])
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
        col = np.asarray(rgb[t])[vs, us]
        order = np.argsort(lab, kind="stable")
        lab, pts, col = lab[order], pts[order], col[order]
        cuts = np.flatnonzero(np.diff(lab)) + 1
        for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(lab)]])):
            per_id.setdefault(int(lab[a]), []).append((pts[a:b], col[a:b]))
    flush()
    clouds: dict[int, tuple[NDArray[np.float32], NDArray[np.uint8]]] = {}
    for iid in sorted(spilled):
        # one instance's points, in frame order as they were spilled
        pcd = o3d.geometry.PointCloud(
            o3d.utility.Vector3dVector(np.fromfile(spill / f"{iid}.xyz", np.float32).reshape(-1, 3).astype(np.float64))
        )
        pcd.colors = o3d.utility.Vector3dVector(
            np.fromfile(spill / f"{iid}.rgb", np.uint8).reshape(-1, 3).astype(np.float64) / 255.0
        )
        (spill / f"{iid}.xyz").unlink()
        (spill / f"{iid}.rgb").unlink()
        pcd = pcd.voxel_down_sample(cfg.structure_voxel if iid in structural else cfg.object_voxel)
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
