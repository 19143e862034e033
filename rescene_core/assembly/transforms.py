"""Small rigid-motion builders used by the attachment rules (world frame, metres, radians).

Every function returns a float64 [4, 4] Sim(3) matrix ``world_from_world``: a correction applied on the
left of a pose, ``world_from_asset_new = correction @ world_from_asset``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from rescene_core.geometry.sim3 import parts_from_sim3


def translation(vector: ArrayLike) -> NDArray[np.float64]:
    """Pure translation by ``vector`` [3] (m)."""
    m = np.eye(4)
    m[:3, 3] = np.asarray(vector, dtype=np.float64)
    return m


def rotation_about(rotvec: ArrayLike, pivot: ArrayLike) -> NDArray[np.float64]:
    """Rotation by the rotation vector ``rotvec`` [3] (radians) about the world point ``pivot`` [3]."""
    rot = Rotation.from_rotvec(np.asarray(rotvec, dtype=np.float64)).as_matrix()
    centre = np.asarray(pivot, dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = centre - rot @ centre
    return m


def align_rotvec(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """Smallest rotation vector [3] turning unit direction ``a`` onto unit direction ``b``."""
    a = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    b = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    axis = np.cross(a, b)
    sin = np.linalg.norm(axis)
    cos = float(np.clip(a @ b, -1.0, 1.0))
    if sin < 1e-12:
        if cos > 0:
            return np.zeros(3)
        # opposite directions: any axis perpendicular to a
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return np.pi * perp / np.linalg.norm(perp)
    return axis / sin * np.arctan2(sin, cos)


def horizontal(v: NDArray, up: NDArray) -> NDArray[np.float64]:
    """Component of ``v`` [3] perpendicular to ``up`` [3] (unit), not normalised."""
    v = np.asarray(v, dtype=np.float64)
    return v - (v @ up) * up


def signed_yaw(a: NDArray, b: NDArray, up: NDArray) -> float:
    """Signed angle (radians) about ``up`` from the horizontal part of ``a`` to that of ``b``."""
    ah, bh = horizontal(a, up), horizontal(b, up)
    return float(np.arctan2(np.cross(ah, bh) @ up, ah @ bh))


def pose_axes(world_from_asset: NDArray) -> NDArray[np.float64]:
    """The asset's unit axes in the world, as the columns of a [3, 3] rotation."""
    _, rot, _ = parts_from_sim3(world_from_asset)
    return rot


def nearest_axis(world_from_asset: NDArray, direction: NDArray, candidates: tuple[int, ...] = (0, 1, 2)):
    """The signed asset axis closest to world ``direction``: (index, sign, world unit vector)."""
    axes = pose_axes(world_from_asset)
    dots = axes.T @ np.asarray(direction, dtype=np.float64)
    idx = max(candidates, key=lambda k: abs(dots[k]))
    sign = 1.0 if dots[idx] >= 0 else -1.0
    return idx, sign, sign * axes[:, idx]


def level_correction(
    world_from_asset: NDArray,
    up: NDArray,
    pivot: NDArray,
    max_tilt_rad: float,
    candidates: tuple[int, ...] = (0, 1, 2),
):
    """Rotation about ``pivot`` putting the asset axis nearest to ``up`` (among ``candidates``) onto ``up``.

    Returns (correction [4, 4], tilt removed in radians); identity when the tilt exceeds ``max_tilt_rad``
    (then the object is lying on purpose or the asset frame is not upright).
    """
    _, _, axis = nearest_axis(world_from_asset, up, candidates)
    rotvec = align_rotvec(axis, up)
    tilt = float(np.linalg.norm(rotvec))
    if tilt < 1e-9 or tilt > max_tilt_rad:
        return np.eye(4), 0.0
    return rotation_about(rotvec, pivot), tilt


def rigid_change(before: NDArray, after: NDArray) -> tuple[float, float]:
    """(translation of the origin in metres, rotation angle in degrees) between two poses."""
    _, r0, t0 = parts_from_sim3(before)
    _, r1, t1 = parts_from_sim3(after)
    cos = (np.trace(r1 @ r0.T) - 1.0) / 2.0
    return float(np.linalg.norm(t1 - t0)), float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
