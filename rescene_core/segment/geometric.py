"""The label-free front end: instance masks for RGB-D scans that have none.

1. TSDF fusion of every frame (Open3D's tensor ``VoxelBlockGrid``) and its surface mesh.
2. Room structure removed: the floor (z near 0 in the aligned frame), a ceiling (a large horizontal
   plane above the cameras) and walls (large vertical planes with almost nothing behind them). A vertex
   joins a plane only if it lies on it and its normal agrees, so the side of a cabinet against a wall
   stays with the cabinet.
3. What is left is clustered (DBSCAN on the thinned vertices); clusters with too few points or smaller
   than a minimum extent are dropped.
4. The labelled mesh is rendered into each camera with a depth test (``rescene_core.segment.project``).

Every segment is labelled ``object`` unless an open_clip checkpoint is given: then the best views of each
segment are classified zero-shot over a vocabulary (``rescene_core.segment.labels``). The result says
which segmenter ran (``geometric`` or ``geometric+clip``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict
from scipy.spatial import cKDTree

from rescene_core.render.raycast import RayCaster
from rescene_core.segment.errors import SegmentError
from rescene_core.segment.labels import zero_shot_labels
from rescene_core.segment.project import labelled_meshes, render_masks


class SegmentConfig(BaseModel):
    """Label-free segmentation. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    tsdf_voxel: float = 0.02
    """TSDF voxel size (m)."""
    sdf_trunc_voxels: float = 4.0
    """TSDF truncation distance in voxels."""
    tsdf_block_count: int = 20000
    """Voxel blocks (8^3 voxels each) the TSDF hash map starts with (it grows when needed)."""
    tsdf_min_weight: float = 1.0
    """Least integration weight (frames) of a TSDF voxel on the extracted surface."""
    depth_trunc: float = 5.0
    """Depth beyond this is not fused (m)."""
    floor_band: float = 0.04
    """Vertices below this height (aligned frame, floor at z = 0) are floor (m)."""
    plane_distance: float = 0.03
    """Distance of a vertex to a wall or ceiling plane to belong to it (m)."""
    plane_normal_deg: float = 30.0
    """Largest angle between a vertex normal and a plane normal for the vertex to join the plane (deg)."""
    plane_iterations: int = 1000
    """RANSAC iterations per plane."""
    max_planes: int = 14
    """Most planes peeled off while looking for walls and the ceiling."""
    vertical_tolerance_deg: float = 10.0
    """Largest tilt of a wall normal from horizontal, and of a ceiling normal from vertical (deg)."""
    wall_min_extent: float = 1.0
    """Least width and height of a wall's inliers (m)."""
    wall_max_behind: float = 0.05
    """Largest share of the scene's points behind a wall plane (seen from the cameras)."""
    ceiling_min_above_cameras: float = 0.1
    """A ceiling lies at least this far above the highest camera (m)."""
    cluster_voxel: float = 0.03
    """Voxel size the object vertices are thinned to before clustering (m)."""
    cluster_eps: float = 0.06
    """DBSCAN neighbourhood radius (m)."""
    cluster_min_points: int = 8
    """DBSCAN core-point neighbour count."""
    min_segment_points: int = 60
    """Fewest thinned points of an object segment."""
    min_segment_extent: float = 0.1
    """Smallest largest-dimension of an object segment (m)."""
    max_segment_extent: float = 4.0
    """Largest largest-dimension of an object segment; bigger clusters are leftovers of the room (m)."""
    depth_abs_tolerance: float = 0.05
    """Mask depth test: absolute tolerance between rendered and measured depth (m)."""
    depth_rel_tolerance: float = 0.05
    """Mask depth test: tolerance as a fraction of the measured depth."""
    min_mask_pixels: int = 30
    """Per frame, a segment's mask with fewer pixels is cleared."""
    support_min_height: float = 0.25
    """A horizontal top higher than this can carry objects that are split off its cluster (m)."""
    support_span_fraction: float = 0.85
    """A part above a top that spans this fraction of the top's width or depth is the piece's own back
    (a chair's or sofa's back, a headboard) and stays with it."""
    support_band: float = 0.03
    """Points more than this above a support top stand on it (m)."""
    structure_band: float = 0.06
    """A cluster lying within this distance of a wall or ceiling plane is a sliver of it (m)..."""
    sliver_thickness: float = 0.03
    """... when it is also thinner than this across the plane (5-95 percentile), unlike a monitor (m)."""
    structure_sliver_fraction: float = 0.8
    """Share of a cluster's points within ``structure_band`` of a plane that makes it a sliver."""
    seed: int = 0
    """Seed of Open3D's RANSAC."""
    clip_views: int = 3
    """Views per segment shown to the zero-shot classifier (the largest masks)."""


@dataclass
class SegmentResult:
    """Masks int32 [T, H, W] (0 = none), labels {id: (label, structural)}, the segmenter's name and a report."""

    masks: NDArray[np.int32]
    labels: dict[int, tuple[str, bool]]
    segmenter: str
    report: dict[str, Any] = field(default_factory=dict)
    mesh_vertices: NDArray[np.float64] | None = None
    mesh_faces: NDArray[np.int64] | None = None
    face_labels: NDArray[np.int64] | None = None


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
    for t in range(len(depth)):
        k = np.asarray(K[t], np.float64).copy()
        k[0, 2] -= 0.5  # Open3D puts pixel centres at integers; the project casts pixel u through u + 0.5
        k[1, 2] -= 0.5
        intr = core.Tensor(k, core.float64)
        cam_from_world = core.Tensor(np.linalg.inv(np.asarray(world_from_cam[t], np.float64)), core.float64)
        d = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(depth[t], np.float32)))
        c = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(rgb[t], np.float32) / 255.0))
        blocks = vbg.compute_unique_block_coordinates(
            d, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels
        )
        vbg.integrate(blocks, d, c, intr, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels)
    mesh = vbg.extract_triangle_mesh(weight_threshold=cfg.tsdf_min_weight).to_legacy()
    mesh.compute_vertex_normals()
    colors = np.asarray(mesh.vertex_colors) if mesh.has_vertex_colors() else np.zeros((len(mesh.vertices), 3))
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, np.int64), np.asarray(mesh.vertex_normals), colors


def _structure(
    verts: NDArray, normals: NDArray, cams: NDArray, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], list[dict[str, Any]]]:
    """Structure label per vertex (0 none, 1 floor, 2.. walls, then ceiling) and the planes found."""
    import open3d as o3d

    o3d.utility.random.seed(cfg.seed)
    labels = np.zeros(len(verts), np.int64)
    labels[verts[:, 2] < cfg.floor_band] = 1
    planes: list[dict[str, Any]] = [{"kind": "floor", "id": 1, "vertices": int((labels == 1).sum())}]
    cos_n = np.cos(np.radians(cfg.plane_normal_deg))
    sin_v = np.sin(np.radians(cfg.vertical_tolerance_deg))
    top_cam = float(cams[:, 2].max()) if len(cams) else 0.0
    centre = cams.mean(axis=0) if len(cams) else verts.mean(axis=0)
    free = labels == 0
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[free]))
    pcd = pcd.voxel_down_sample(cfg.cluster_voxel)
    thin = np.asarray(pcd.points)
    rest = pcd
    next_id = 2
    walls: list[tuple[NDArray, float]] = []
    ceiling: tuple[NDArray, float] | None = None
    for _ in range(cfg.max_planes):
        if len(rest.points) < 200:
            break
        (a, b, c, d), inl = rest.segment_plane(cfg.plane_distance, 3, cfg.plane_iterations)
        n = np.array([a, b, c])
        n, d = n / np.linalg.norm(n), d / np.linalg.norm(n)
        pts = np.asarray(rest.points)[inl]
        rest = rest.select_by_index(inl, invert=True)
        if len(inl) < 200:
            break
        if n @ (centre - 0) + d < 0:  # orient towards the cameras (into the room)
            n, d = -n, -d
        if abs(n[2]) < sin_v:
            horiz = np.cross(n, [0.0, 0.0, 1.0])
            horiz /= np.linalg.norm(horiz)
            width = float(np.ptp(pts @ horiz))
            height = float(np.ptp(pts[:, 2]))
            behind = float(((thin @ n + d) < -cfg.plane_distance * 2).mean()) if len(thin) else 1.0
            if width >= cfg.wall_min_extent and height >= cfg.wall_min_extent and behind <= cfg.wall_max_behind:
                walls.append((n, d))
        elif abs(n[2]) > np.cos(np.radians(cfg.vertical_tolerance_deg)):
            z = float(np.median(pts[:, 2]))
            if z > top_cam + cfg.ceiling_min_above_cameras and (ceiling is None or z > -ceiling[1]):
                ceiling = (np.array([0.0, 0.0, -1.0]), z)
    for n, d in walls:
        on = free & (np.abs(verts @ n + d) < cfg.plane_distance) & (np.abs(normals @ n) > cos_n)
        labels[on] = next_id
        planes.append({"kind": "wall", "id": next_id, "normal": n.round(4).tolist(), "offset": round(float(d), 4),
                       "vertices": int(on.sum())})  # fmt: skip
        free &= ~on
        next_id += 1
    if ceiling is not None:
        _, z = ceiling
        on = free & (verts[:, 2] > z - cfg.plane_distance) & (np.abs(normals[:, 2]) > cos_n)
        on |= free & (verts[:, 2] > z + cfg.plane_distance)
        labels[on] = next_id
        planes.append({"kind": "ceiling", "id": next_id, "height": round(z, 4), "vertices": int(on.sum())})
    return labels, planes


def _dbscan(points: NDArray, eps: float, min_points: int) -> NDArray[np.int64]:
    import open3d as o3d

    if len(points) == 0:
        return np.zeros(0, np.int64)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return np.asarray(pcd.cluster_dbscan(eps, min_points, print_progress=False), np.int64)


def _split_on_support(pts: NDArray, nrm: NDArray, cfg: SegmentConfig) -> list[NDArray[np.int64]]:
    """Indices of the parts of one cluster: the support (a table and what is under its top) first, then
    each group of points standing on its top surface that is narrower than the top both ways (what spans
    the top is the piece's own back). A cluster with no large horizontal top is one part."""
    up = nrm[:, 2] > np.cos(np.radians(cfg.vertical_tolerance_deg))
    high = up & (pts[:, 2] > cfg.support_min_height)
    if high.sum() < cfg.min_segment_points:
        return [np.arange(len(pts))]
    z = pts[high, 2]
    bins = np.arange(z.min(), z.max() + 2 * cfg.cluster_voxel, cfg.cluster_voxel)
    hist, edges = np.histogram(z, bins=bins)
    k = int(np.argmax(hist))
    if hist[k] < cfg.min_segment_points:
        return [np.arange(len(pts))]
    top = float(edges[k] + edges[k + 1]) / 2
    above = np.flatnonzero(pts[:, 2] > top + cfg.support_band)
    if len(above) < cfg.min_segment_points:
        return [np.arange(len(pts))]
    lab = _dbscan(pts[above], cfg.cluster_eps, cfg.cluster_min_points)
    on_top = up & (np.abs(pts[:, 2] - top) <= cfg.support_band)
    top_span = np.ptp(pts[on_top, :2], axis=0) if on_top.sum() >= 2 else np.zeros(2)
    parts, taken = [], np.zeros(len(pts), bool)
    for c in range(lab.max() + 1 if len(lab) else 0):
        idx = above[lab == c]
        spans = np.ptp(pts[idx, :2], axis=0) >= cfg.support_span_fraction * top_span
        if len(idx) >= cfg.min_segment_points and not spans.any():
            parts.append(idx)
            taken[idx] = True
    if not parts:
        return [np.arange(len(pts))]
    return [np.flatnonzero(~taken)] + parts


def _clusters(
    verts: NDArray, normals: NDArray, free: NDArray[np.bool_], cfg: SegmentConfig
) -> tuple[NDArray[np.int64], dict]:
    """Cluster label per vertex (0 = none, 1..k) of the free vertices, and counts for the report.

    Objects on a table touch it, so a cluster with a large horizontal top is split: what stands on the
    top becomes its own segment (``_split_on_support``)."""
    import open3d as o3d

    out = np.zeros(len(verts), np.int64)
    idx = np.flatnonzero(free)
    stats = {"clusters": 0, "kept": 0, "split_off_supports": 0, "too_small": 0, "too_large": 0, "noise_points": 0}
    if len(idx) < cfg.min_segment_points:
        return out, stats
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[idx]))
    pcd.normals = o3d.utility.Vector3dVector(normals[idx])
    pcd = pcd.voxel_down_sample(cfg.cluster_voxel)
    thin = np.asarray(pcd.points)
    tn = np.asarray(pcd.normals)
    tn = tn / np.maximum(np.linalg.norm(tn, axis=1, keepdims=True), 1e-9)
    lab = _dbscan(thin, cfg.cluster_eps, cfg.cluster_min_points)
    stats["noise_points"] = int((lab < 0).sum())
    seg = np.zeros(len(thin), np.int64)
    nxt = 1
    groups = [np.flatnonzero(lab == c) for c in range(lab.max() + 1 if len(lab) else 0)]
    stats["clusters"] = len(groups)
    while groups:
        members = groups.pop()
        ext = float(np.ptp(thin[members], axis=0).max())
        if ext > cfg.max_segment_extent and len(members) >= 2 * cfg.min_segment_points:
            # a cluster bigger than furniture is several objects bridged by a few points: cluster it tighter
            sub = _dbscan(thin[members], cfg.cluster_eps * 0.5, cfg.cluster_min_points)
            if sub.max(initial=-1) >= 1:
                stats["resplit"] = stats.get("resplit", 0) + 1
                groups += [members[sub == c] for c in range(sub.max() + 1)]
                continue
        parts = _split_on_support(thin[members], tn[members], cfg)
        stats["split_off_supports"] += len(parts) - 1
        for part in parts:
            pts = thin[members[part]]
            ext = float(np.ptp(pts, axis=0).max()) if len(pts) else 0.0
            if len(pts) < cfg.min_segment_points or ext < cfg.min_segment_extent:
                stats["too_small"] += 1
                continue
            if ext > cfg.max_segment_extent:
                stats["too_large"] += 1
                continue
            seg[members[part]] = nxt
            nxt += 1
    stats["kept"] = nxt - 1
    dist, near = cKDTree(thin).query(verts[idx], k=1, distance_upper_bound=cfg.cluster_voxel * 1.5)
    ok = np.isfinite(dist)
    out[idx[ok]] = seg[near[ok]]
    return out, stats


def _absorb_structure(
    verts: NDArray,
    struct: NDArray[np.int64],
    clusters: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> int:
    """Clusters that are slivers of a wall or the ceiling (most of their points within ``structure_band``
    of its plane) join it; returns how many did. Edits ``struct`` and ``clusters`` in place."""
    joined = 0
    for c in np.unique(clusters[clusters > 0]):
        sel = clusters == c
        p = verts[sel]
        for plane in planes:
            if plane["kind"] == "wall":
                dist = np.abs(p @ np.asarray(plane["normal"]) + plane["offset"])
            elif plane["kind"] == "ceiling":
                dist = np.abs(p[:, 2] - plane["height"])
            else:
                continue
            thick = float(np.subtract(*np.percentile(dist, [95, 5])))
            if (dist < cfg.structure_band).mean() >= cfg.structure_sliver_fraction and thick < cfg.sliver_thickness:
                struct[sel] = plane["id"]
                clusters[sel] = 0
                joined += 1
                break
    return joined


def segment_geometric(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    config: SegmentConfig | None = None,
    clip_model: str | None = None,
    clip_model_name: str = "ViT-B-32",
    vocabulary: tuple[str, ...] = ("object",),
) -> SegmentResult:
    """Label-free instances of an aligned RGB-D capture (world z up, floor at z = 0).

    rgb [T, H, W, 3] uint8, depth [T, H, W] float32 metres (0 invalid), K [T, 3, 3], world_from_cam
    [T, 4, 4] (OpenCV axes). clip_model: a local open_clip checkpoint to label segments zero-shot.
    """

    cfg = config or SegmentConfig()
    T, H, W = depth.shape
    verts, faces, normals, _ = tsdf_mesh(rgb, depth, K, world_from_cam, cfg)
    if len(faces) == 0:
        raise SegmentError("TSDF fusion produced no surface (no valid depth in range; check --depth-scale)")
    cams = np.asarray(world_from_cam)[:, :3, 3]
    struct, planes = _structure(verts, normals, cams, cfg)
    clusters, cstats = _clusters(verts, normals, struct == 0, cfg)
    cstats["joined_structure"] = _absorb_structure(verts, struct, clusters, planes, cfg)
    kept = np.unique(clusters[clusters > 0])
    remap = np.zeros(int(clusters.max()) + 1, np.int64)
    remap[kept] = np.arange(1, len(kept) + 1)
    clusters = remap[clusters]
    n_struct = max(int(p["id"]) for p in planes)
    vlabel = np.where(struct > 0, struct, np.where(clusters > 0, clusters + n_struct, 0))
    # a face takes the label two or three of its vertices share, else none
    fl = vlabel[faces]
    face_label = np.where(
        (fl[:, 0] == fl[:, 1]) | (fl[:, 0] == fl[:, 2]), fl[:, 0], np.where(fl[:, 1] == fl[:, 2], fl[:, 1], 0)
    )
    caster = RayCaster(labelled_meshes(verts, faces, face_label))
    masks, rstats = render_masks(
        caster, K, world_from_cam, W, H, depth, cfg.depth_abs_tolerance, cfg.depth_rel_tolerance
    )
    for t in range(T):
        counts = np.bincount(masks[t].ravel())
        small = np.flatnonzero((counts > 0) & (counts < cfg.min_mask_pixels))
        small = small[small > 0]
        if len(small):
            masks[t][np.isin(masks[t], small)] = 0
    present = {int(i) for i in np.unique(masks) if i > 0}
    kinds = {p["id"]: p["kind"] for p in planes}
    labels: dict[int, tuple[str, bool]] = {}
    for i in sorted(present):
        labels[i] = (kinds[i], True) if i in kinds else ("object", False)
    objects = [i for i in labels if not labels[i][1]]
    if not objects:
        raise SegmentError(
            f"empty scene after segmentation: {cstats['clusters']} clusters, none kept as an object "
            f"({cstats['too_small']} smaller than {cfg.min_segment_extent} m or {cfg.min_segment_points} points, "
            f"{cstats['too_large']} larger than {cfg.max_segment_extent} m); the recording may not show objects "
            "clear of the floor and walls"
        )
    segmenter = "geometric"
    label_report: dict[str, Any] = {"labeller": "none (every segment is 'object')"}
    if clip_model:
        names, label_report = zero_shot_labels(
            rgb, masks, objects, clip_model, clip_model_name, vocabulary, cfg.clip_views
        )
        for i, name in names.items():
            labels[i] = (name, False)
        segmenter = "geometric+clip"
    report = {
        "segmenter": segmenter,
        "mesh": {"vertices": int(len(verts)), "faces": int(len(faces)), "tsdf_voxel": cfg.tsdf_voxel},
        "planes": planes,
        "clusters": cstats,
        "render": rstats,
        "objects": len(objects),
        "structural": len(labels) - len(objects),
        "labels": label_report,
        "config": cfg.model_dump(mode="json"),
    }
    return SegmentResult(masks, labels, segmenter, report, verts, faces, face_label)
