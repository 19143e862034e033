"""Similarity transforms Sim(3) as 4x4 matrices, and their Lie algebra sim(3).

A Sim(3) element is stored as a float64 [4, 4] matrix ``[[s R, t], [0, 1]]`` with ``s > 0`` and
``R`` in SO(3); it maps points as ``x -> s R x + t``. Names follow ``a_from_b``: ``world_from_asset``
maps asset-frame points into the world frame.

The tangent vector of sim(3) is ordered ``xi = [rho (3), omega (3), sigma]``: ``omega`` is the
rotation vector (radians), ``sigma = log(s)`` and ``rho`` the translational part, so that

    exp(xi) = expm([[sigma I + [omega]_x, rho], [0, 0]]).

The left Jacobian ``W`` that links ``rho`` to ``t`` is an integral over [0, 1] of a smooth, entire
integrand; it is evaluated by Gauss-Legendre quadrature, which is exact to machine precision for the
angles (<= pi) and log-scales (|sigma| <= ~20) that occur, with no small-angle special cases.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

Matrix4 = NDArray[np.float64]
"""float64 [4, 4] homogeneous Sim(3) matrix."""

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(32)
_GL_U = 0.5 * (_GL_NODES + 1.0)  # nodes mapped to [0, 1]
_GL_W = 0.5 * _GL_WEIGHTS


class Sim3Error(ValueError):
    """Raised when a matrix is not a valid similarity transform."""


def hat(omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """Skew-symmetric [3, 3] matrix of a 3-vector, ``hat(a) @ b == cross(a, b)``."""
    x, y, z = np.asarray(omega, dtype=np.float64)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def sim3_from_parts(scale: float, rotation: NDArray[np.float64], translation: NDArray[np.float64]) -> Matrix4:
    """Build ``[[s R, t], [0, 1]]`` from scale s (> 0), rotation R [3, 3] and translation t [3] (m)."""
    if not scale > 0 or not np.isfinite(scale):
        raise Sim3Error(f"scale must be a finite positive number, got {scale!r}")
    m = np.eye(4)
    m[:3, :3] = scale * np.asarray(rotation, dtype=np.float64)
    m[:3, 3] = np.asarray(translation, dtype=np.float64)
    return m


def scale_of(m: NDArray) -> float:
    """Uniform scale of a 4x4 (or 3x3) transform: the cube root of |det| of its linear part (0 when singular)."""
    return float(np.cbrt(abs(np.linalg.det(np.asarray(m, dtype=np.float64)[:3, :3]))))


def parts_from_sim3(m: Matrix4) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Split a Sim(3) matrix into (scale, rotation [3, 3], translation [3])."""
    m = np.asarray(m, dtype=np.float64)
    a = m[:3, :3]
    det = np.linalg.det(a)
    if not np.isfinite(det) or det <= 0:
        raise Sim3Error(f"linear part has determinant {det!r}; a similarity needs det > 0")
    scale = float(np.cbrt(det))
    return scale, a / scale, m[:3, 3].copy()


def check_sim3(m: Matrix4, atol: float = 1e-6) -> list[str]:
    """Return the reasons ``m`` is not a Sim(3) matrix (empty when it is)."""
    m = np.asarray(m, dtype=np.float64)
    if m.shape != (4, 4):
        return [f"shape is {m.shape}, expected (4, 4)"]
    if not np.all(np.isfinite(m)):
        return ["contains NaN or infinite values"]
    problems = []
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], atol=atol):
        problems.append(f"last row is {m[3].tolist()}, expected [0, 0, 0, 1]")
    try:
        scale, rot, _ = parts_from_sim3(m)
    except Sim3Error as err:
        return [*problems, str(err)]
    deviation = np.abs(rot.T @ rot - np.eye(3)).max()
    if deviation > atol:
        problems.append(f"linear part is not a scaled rotation (|R^T R - I| = {deviation:.2e})")
    return problems


def compose(a_from_b: Matrix4, b_from_c: Matrix4) -> Matrix4:
    """``a_from_c = a_from_b * b_from_c``."""
    return np.asarray(a_from_b, dtype=np.float64) @ np.asarray(b_from_c, dtype=np.float64)


def inverse(a_from_b: Matrix4) -> Matrix4:
    """``b_from_a``: the exact inverse ``[[R^T / s, -R^T t / s], [0, 1]]``."""
    scale, rot, trans = parts_from_sim3(a_from_b)
    return sim3_from_parts(1.0 / scale, rot.T, -(rot.T @ trans) / scale)


def apply(a_from_b: Matrix4, points_b: NDArray) -> NDArray[np.float64]:
    """Map points [n, 3] (or one point [3]) from frame b to frame a."""
    m = np.asarray(a_from_b, dtype=np.float64)
    pts = np.asarray(points_b, dtype=np.float64)
    return pts @ m[:3, :3].T + m[:3, 3]


def _left_jacobian(omega: NDArray[np.float64], sigma: float) -> NDArray[np.float64]:
    """W = int_0^1 exp(sigma u) exp(u [omega]_x) du, the map from rho to the translation."""
    theta = float(np.linalg.norm(omega))
    u = _GL_U
    e = np.exp(sigma * u)
    a = float(np.sum(_GL_W * e))
    # sin(theta u) / theta and (1 - cos(theta u)) / theta^2 written through sinc: no 0/0 at theta = 0.
    b = float(np.sum(_GL_W * e * u * np.sinc(theta * u / np.pi)))
    c = float(np.sum(_GL_W * e * 0.5 * u**2 * np.sinc(theta * u / (2.0 * np.pi)) ** 2))
    k = hat(omega)
    return a * np.eye(3) + b * k + c * (k @ k)


def exp(xi: NDArray[np.float64]) -> Matrix4:
    """sim(3) tangent ``[rho, omega, sigma]`` (7,) -> Sim(3) matrix."""
    xi = np.asarray(xi, dtype=np.float64)
    if xi.shape != (7,):
        raise Sim3Error(f"tangent must have shape (7,), got {xi.shape}")
    rho, omega, sigma = xi[:3], xi[3:6], float(xi[6])
    rot = Rotation.from_rotvec(omega).as_matrix()
    return sim3_from_parts(float(np.exp(sigma)), rot, _left_jacobian(omega, sigma) @ rho)


def log(m: Matrix4) -> NDArray[np.float64]:
    """Sim(3) matrix -> tangent ``[rho, omega, sigma]`` (7,), rotation angle in [0, pi]."""
    scale, rot, trans = parts_from_sim3(m)
    omega = Rotation.from_matrix(rot).as_rotvec()
    sigma = float(np.log(scale))
    rho = np.linalg.solve(_left_jacobian(omega, sigma), trans)
    return np.concatenate([rho, omega, [sigma]])


def scale_by_confidence(m: Matrix4, weight: float) -> Matrix4:
    """``exp(w log(m))``: identity at w = 0, ``m`` at w = 1, the geodesic in between (paper Eq. 5)."""
    return exp(float(weight) * log(m))


def rotation_angle(rot: NDArray[np.float64]) -> float:
    """Geodesic distance of a rotation [3, 3] from the identity, radians in [0, pi]."""
    cos = (np.trace(np.asarray(rot, dtype=np.float64)) - 1.0) / 2.0
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))
