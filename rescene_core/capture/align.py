"""Gravity and floor alignment of a recording: the world rotated to z up with the floor at z = 0.

Real recorders keep their own world axes (a HoloLens world is y up; ScanNet's is z up with the floor
anywhere). The cameras say roughly where up is (their image y axis points down); the floor plane of the
fused geometry says it precisely. ``estimate_alignment`` finds the floor as the lowest large plane whose
normal is near the cameras' up, rotates its normal to +z, turns the dominant wall direction onto the x
axis, and puts the floor at z = 0. The transform ``aligned_from_source`` is kept in the capture's
attributes so that every output maps back to the source frame (``source_from_aligned`` = its inverse).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict


class AlignConfig(BaseModel):
    """Floor and gravity finding. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    voxel: float = 0.04
    """Voxel size the fused points are thinned to before plane fitting (m)."""
    ransac_distance: float = 0.03
    """RANSAC inlier distance of a plane (m)."""
    ransac_iterations: int = 1000
    """RANSAC iterations per plane."""
    max_planes: int = 8
    """Most planes peeled off the points while looking for the floor."""
    max_tilt_deg: float = 20.0
    """Largest angle between a floor candidate's normal and the cameras' up (deg)."""
    min_floor_fraction: float = 0.03
    """Least share of the thinned points a floor candidate holds."""
    min_camera_height: float = 0.3
    """The floor lies at least this far below the mean camera centre, along up (m)."""
    refine_band: float = 0.02
    """Half-width of the slab the floor plane is refitted to by least squares (m)."""
    yaw: bool = True
    """Turn the dominant wall direction onto the x axis (plans and exports read better)."""
    seed: int = 0
    """Seed of Open3D's RANSAC."""


@dataclass(frozen=True)
class Alignment:
    """The transform into the aligned frame and how it was found.

    aligned_from_source: float64 [4, 4] rigid. floor_normal_source: unit [3] floor normal in the source
    frame (up). camera_up_source: unit [3] the cameras' mean up in the source frame. method: 'floor' (a
    floor plane was found), 'cameras' (no floor plane: the cameras' up and the lowest points) or 'none'.
    floor_inliers: points on the floor plane. floor_residual: RMS distance of those inliers to the plane (m).
    """

    aligned_from_source: NDArray[np.float64]
    floor_normal_source: NDArray[np.float64]
    camera_up_source: NDArray[np.float64]
    method: str
    floor_inliers: int = 0
    floor_residual: float = 0.0
    yaw_deg: float = 0.0

    @property
    def source_from_aligned(self) -> NDArray[np.float64]:
        return rigid_inverse(self.aligned_from_source)

    @property
    def camera_up_angle_deg(self) -> float:
        """Angle between the floor normal and the cameras' mean up (deg)."""
        c = float(np.clip(self.floor_normal_source @ self.camera_up_source, -1.0, 1.0))
        return float(np.degrees(np.arccos(c)))

    def to_json(self) -> dict[str, Any]:
        return {
            "aligned_from_source": self.aligned_from_source.tolist(),
            "source_from_aligned": self.source_from_aligned.tolist(),
            "floor_normal_source": self.floor_normal_source.tolist(),
            "camera_up_source": self.camera_up_source.tolist(),
            "floor_to_camera_up_deg": round(self.camera_up_angle_deg, 3),
            "method": self.method,
            "floor_inliers": int(self.floor_inliers),
            "floor_residual_m": round(float(self.floor_residual), 5),
            "yaw_deg": round(float(self.yaw_deg), 3),
        }


def rigid_inverse(a_from_b: NDArray) -> NDArray[np.float64]:
    out = np.eye(4)
    rot = np.asarray(a_from_b, np.float64)[:3, :3]
    out[:3, :3] = rot.T
    out[:3, 3] = -rot.T @ np.asarray(a_from_b, np.float64)[:3, 3]
    return out


def camera_up(world_from_cam: NDArray) -> NDArray[np.float64]:
    """The cameras' mean up direction [3] (minus the image y axis, OpenCV cameras), unit."""
    up = -np.asarray(world_from_cam, np.float64)[:, :3, 1].mean(axis=0)
    n = np.linalg.norm(up)
    if n < 1e-6:
        raise ValueError("the cameras' up directions cancel out; cannot tell where up is")
    return up / n


def rotation_between(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """The smallest rotation [3, 3] taking unit vector a onto unit vector b."""
    a = np.asarray(a, np.float64) / np.linalg.norm(a)
    b = np.asarray(b, np.float64) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1 + 1e-12:  # opposite: a half turn about any axis perpendicular to a
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


def _fit_plane(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
    """Least-squares plane of points [n, 3]: unit normal, offset d (n.x + d = 0), RMS residual."""
    c = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - c, full_matrices=False)
    n = vt[2]
    return n, float(-n @ c), float(s[2] / np.sqrt(max(len(points), 1)))


def _dominant_yaw(points: NDArray[np.float64], voxel: float) -> float:
    """Angle (rad) of the dominant horizontal normal direction modulo 90 deg (walls, furniture sides)."""
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 3, max_nn=30))
    n = np.asarray(pcd.normals)
    side = np.abs(n[:, 2]) < 0.2
    if side.sum() < 50:
        return 0.0
    ang = np.arctan2(n[side, 1], n[side, 0])
    w = np.hypot(n[side, 0], n[side, 1])
    return float(np.angle(np.sum(w * np.exp(4j * ang))) / 4.0)


def estimate_alignment(points: NDArray, world_from_cam: NDArray, config: AlignConfig | None = None) -> Alignment:
    """Find the floor in ``points`` [n, 3] (fused geometry, source frame) and the transform to z up.

    world_from_cam: [T, 4, 4] source-frame camera poses (OpenCV axes): their mean up orients the search,
    and the floor must lie below them.
    """
    import open3d as o3d

    cfg = config or AlignConfig()
    pts = np.asarray(points, np.float64)
    pts = pts[np.isfinite(pts).all(axis=1)]
    up = camera_up(world_from_cam)
    cam_height = float((np.asarray(world_from_cam)[:, :3, 3] @ up).mean())
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts)).voxel_down_sample(cfg.voxel)
    thin = np.asarray(pcd.points)
    o3d.utility.random.seed(cfg.seed)
    best: tuple[float, NDArray, float, int] | None = None  # (height, normal, offset, inliers)
    rest = pcd
    cos_tilt = np.cos(np.radians(cfg.max_tilt_deg))
    min_inliers = max(50, int(cfg.min_floor_fraction * len(thin)))
    for _ in range(cfg.max_planes):
        if len(rest.points) < min_inliers:
            break
        (a, b, c, d), inl = rest.segment_plane(cfg.ransac_distance, 3, cfg.ransac_iterations)
        n = np.array([a, b, c])
        norm = np.linalg.norm(n)
        n, d = n / norm, d / norm
        if n @ up < 0:
            n, d = -n, -d
        height = -d  # n . x = height on the plane
        if len(inl) >= min_inliers and n @ up >= cos_tilt and height <= cam_height - cfg.min_camera_height:
            if best is None or height < best[0]:
                best = (height, n, d, len(inl))
        rest = rest.select_by_index(inl, invert=True)
    if best is None:
        # no floor plane: trust the cameras' up, and put the floor at the 1st percentile of heights
        normal = up
        height = float(np.percentile(thin @ up, 1.0)) if len(thin) else cam_height - 1.5
        method, inliers, resid = "cameras", 0, 0.0
    else:
        _, n0, d0, _ = best
        band = np.abs(thin @ n0 + d0) < cfg.refine_band
        normal, d, resid = _fit_plane(thin[band]) if band.sum() >= 3 else (n0, d0, 0.0)
        if normal @ up < 0:
            normal, d = -normal, -d
        height = -d
        method, inliers = "floor", int(band.sum())
    rot = rotation_between(normal, [0.0, 0.0, 1.0])
    yaw = 0.0
    if cfg.yaw and len(thin) >= 50:
        yaw = _dominant_yaw(thin @ rot.T, cfg.voxel)
        cz, sz = np.cos(-yaw), np.sin(-yaw)
        rot = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]]) @ rot
    aligned_from_source = np.eye(4)
    aligned_from_source[:3, :3] = rot
    aligned_from_source[2, 3] = -height  # the floor's height along its normal becomes z = 0
    return Alignment(
        aligned_from_source=aligned_from_source,
        floor_normal_source=np.asarray(normal, np.float64),
        camera_up_source=up,
        method=method,
        floor_inliers=inliers,
        floor_residual=float(resid),
        yaw_deg=float(np.degrees(yaw)),
    )


def identity_alignment(world_from_cam: NDArray) -> Alignment:
    """No alignment (the source is already z up with its floor where it is)."""
    return Alignment(np.eye(4), np.array([0.0, 0.0, 1.0]), camera_up(world_from_cam), "none")


def apply_alignment(alignment: Alignment, world_from_cam: NDArray) -> NDArray[np.float64]:
    """Camera poses [T, 4, 4] in the aligned frame."""
    return np.einsum("ij,tjk->tik", alignment.aligned_from_source, np.asarray(world_from_cam, np.float64))


def transform_points(a_from_b: NDArray, points: NDArray) -> NDArray:
    """Points [n, 3] mapped by a rigid 4x4 (dtype kept)."""
    p = np.asarray(points)
    out = p.astype(np.float64) @ np.asarray(a_from_b)[:3, :3].T + np.asarray(a_from_b)[:3, 3]
    return out.astype(p.dtype)
