"""TSDF fusion of the frames into a coloured surface mesh, and steps 1-3 shared by both front ends."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.geometry.open3d_rng import seeded_open3d_rng
from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import ScanPoints, scan_points
from rescene_core.segment.geometric.structure import _structure


def tsdf_mesh(
    rgb: NDArray[np.uint8], depth: NDArray[np.float32], K: NDArray, world_from_cam: NDArray, cfg: SegmentConfig
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """TSDF-fused surface: vertices [v, 3], faces [f, 3], vertex normals [v, 3] (world frame), vertex
    colours [v, 3] in [0, 1]."""
    import open3d as o3d

    core = o3d.core
    # the tensor VoxelBlockGrid (the legacy ScalableTSDFVolume of the open3d 0.20 wheel integrates nothing)
    vbg = o3d.t.geometry.VoxelBlockGrid(
        attr_names=("tsdf", "weight", "color"),
        attr_dtypes=(core.float32, core.float32, core.float32),
        attr_channels=((1), (1), (3)),
        voxel_size=cfg.tsdf_voxel,
        block_resolution=8,
        block_count=cfg.tsdf_block_count,
        device=core.Device("CPU:0"),
    )
    step = max(min(int(cfg.tsdf_stride), depth.shape[2] // max(cfg.tsdf_min_width, 1)), 1)
    for t in range(len(depth)):
        k = np.asarray(K[t], np.float64).copy()
        # Open3D puts pixel centres at integers; the project casts pixel u through u + 0.5. Pixel i of the
        # strided image is pixel step * i of the full one, whose centre is at step * i + 0.5.
        k[0, 2] = (k[0, 2] - 0.5) / step
        k[1, 2] = (k[1, 2] - 0.5) / step
        k[:2, :2] /= step
        intr = core.Tensor(k, core.float64)
        cam_from_world = core.Tensor(np.linalg.inv(np.asarray(world_from_cam[t], np.float64)), core.float64)
        d = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(depth[t][::step, ::step], np.float32)))
        c = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(rgb[t][::step, ::step], np.float32) / 255.0))
        blocks = vbg.compute_unique_block_coordinates(
            d, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels
        )
        vbg.integrate(blocks, d, c, intr, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels)
    mesh = vbg.extract_triangle_mesh(weight_threshold=cfg.tsdf_min_weight).to_legacy()
    mesh.compute_vertex_normals()
    colors = np.asarray(mesh.vertex_colors) if mesh.has_vertex_colors() else np.zeros((len(mesh.vertices), 3))
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, np.int64), np.asarray(mesh.vertex_normals), colors


def fuse_scan(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    cfg: SegmentConfig,
    fh_k: float | None = None,
) -> tuple[NDArray, NDArray[np.int64], NDArray[np.int64], list[dict[str, Any]], ScanPoints, dict[str, float]]:
    """Steps 1-3 shared by both front ends: mesh vertices [v, 3], faces [f, 3], structure label per vertex,
    the planes, the superpoints and the seconds each step took."""
    seconds: dict[str, float] = {}
    # Open3D on one thread, its engine seeded: on several, the TSDF's surface and the RANSAC planes differ
    # from run to run (a wall's offset by 0.5 mm, a few superpoints more or less, objects matched or not)
    with seeded_open3d_rng(cfg.seed):
        t = time.perf_counter()
        verts, faces, normals, colours = tsdf_mesh(rgb, depth, K, world_from_cam, cfg)
        if len(faces) == 0:
            raise SegmentError("TSDF fusion produced no surface (no valid depth in range; check --depth-scale)")
        seconds["tsdf"] = time.perf_counter() - t
        t = time.perf_counter()
        cams = np.asarray(world_from_cam)[:, :3, 3]
        struct, planes = _structure(verts, normals, cams, cfg)
        seconds["structure"] = time.perf_counter() - t
        t = time.perf_counter()
        sp = scan_points(verts, normals, colours, struct, planes, cfg, fh_k)
        seconds["superpoints"] = time.perf_counter() - t
    return verts, faces, struct, planes, sp, seconds
