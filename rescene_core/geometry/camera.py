"""Pinhole cameras in the project's convention: OpenCV axes (x right, y down, z forward), world z up,
poses as world_from_cam [4, 4], intrinsics K [3, 3] in pixels."""

from __future__ import annotations

import numpy as np
from numpy.typing import DTypeLike, NDArray

UP = np.array([0.0, 0.0, 1.0])


def look_at(eye: NDArray, target: NDArray, roll: float = 0.0, strict: bool = True) -> NDArray[np.float64]:
    """world_from_cam [4, 4] of a camera at ``eye`` [3] looking at ``target`` [3] (metres, world frame).

    The camera's x axis stays horizontal (world z up), then the image turns by ``roll`` (radians) about
    the viewing axis. Looking straight up or down leaves the yaw undefined: ``strict`` raises ValueError,
    otherwise x is world +x. Raises ValueError when eye and target coincide.
    """
    eye = np.asarray(eye, float)
    z = np.asarray(target, float) - eye
    norm = np.linalg.norm(z)
    if not norm > 1e-12:
        raise ValueError(f"look_at: eye {eye.tolist()} and target coincide")
    z /= norm
    x = np.cross(z, UP)
    if np.linalg.norm(x) < 1e-6:
        if strict:
            raise ValueError("look_at: looking straight up or down has no defined yaw")
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    if roll:
        c, s = np.cos(roll), np.sin(roll)
        x, y = c * x + s * y, -s * x + c * y
    out = np.eye(4)
    out[:3, :3] = np.stack([x, y, z], axis=1)
    out[:3, 3] = eye
    return out


def intrinsics_from_fov(width: int, height: int, hfov_deg: float) -> NDArray[np.float64]:
    """K [3, 3] (pixels) of square pixels with horizontal field of view ``hfov_deg`` and the principal
    point at the image centre (width / 2, height / 2)."""
    f = width / 2 / np.tan(np.radians(hfov_deg) / 2)
    return np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])


def project(
    points_world: NDArray,
    K: NDArray[np.float64],
    world_from_cam: NDArray[np.float64],
    dtype: DTypeLike = np.float64,
) -> tuple[NDArray, NDArray, NDArray]:
    """Pixel coordinates (u right, v down) and depth along the camera z of world points [n, 3].

    Returns (u [n], v [n], z [n]) in ``dtype`` (float32 halves the memory of large clouds); u and v are
    inf or nan for points at z = 0. cam_from_world is never formed: (p - c) @ R gives camera coordinates.
    """
    rot = np.asarray(world_from_cam[:3, :3], dtype=dtype)
    centre = np.asarray(world_from_cam[:3, 3], dtype=dtype)
    cam = (points_world - centre) @ rot
    z = cam[:, 2]
    cast = np.dtype(dtype).type
    with np.errstate(divide="ignore", invalid="ignore"):
        u = cam[:, 0] / z * cast(K[0, 0]) + cast(K[0, 2])
        v = cam[:, 1] / z * cast(K[1, 1]) + cast(K[1, 2])
    return u, v, z


def project_to_pixels(
    points_world: NDArray[np.float32],
    K: NDArray[np.float64],
    world_from_cam: NDArray[np.float64],
    width: int,
    height: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]:
    """Pixel (column, row) of world points [n, 3] in a pinhole camera, computed in float32.

    Returns (col [n], row [n], valid [n]); valid means finite, in front of the camera (z > 0) and inside
    the image. col/row are 0 where not valid.
    """
    u, v, z = project(points_world, K, world_from_cam, np.float32)
    valid = (z > 0) & np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    col = np.where(valid, u, 0).astype(np.int64)
    row = np.where(valid, v, 0).astype(np.int64)
    return col, row, valid
