"""Bounded Sim(3) ICP (paper Eq. 3 and Appendix 'Registration Details').

Each iteration pairs every target point with its nearest source sample, rejects pairs farther than
``max_distance_ratio`` of the target extent, keeps the pairs below the ``keep_quantile`` distance
quantile, and solves the closed-form similarity (Umeyama) on them. The update is then bounded:

* the per-step rotation ``dR = R_umeyama R^T`` is clamped to ``max_step_rotation_deg`` (geodesic);
* the per-step scale ``ds = s_umeyama / s`` is pulled towards 1 by ``scale_regularization`` (lambda):
  ``log ds <- (1 - lambda) log ds``;
* the scale is clipped to ``[scale_min, scale_max]`` times the initial scale ``s0`` after each step;
* the accumulated refinement rotation ``dR_ref = R R0^T`` is clamped to ``max_total_rotation_deg``;
* the translation is the least-squares optimum for the bounded (s, R) on the kept pairs.

All poses are ``world_from_asset`` float64 [4, 4] Sim(3) matrices; the source is in the asset frame,
the target in the world frame (metres).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.registration.fit import KD_LEAF_SIZE


@dataclass(frozen=True)
class IcpResult:
    """Outcome of the bounded ICP.

    world_from_asset: the refined pose. iterations: steps taken. stop_reason: 'converged',
    'max_iterations' or 'too_few_correspondences'. history: per-step residual and clamp records.
    step_clamps / total_clamps / scale_clips: how often each bound was active.
    state: the solver's own (scale, rotation [3, 3], translation [3]) after the last step, from which
    ``bounded_sim3_icp(..., resume=result)`` continues exactly as an uninterrupted run would.
    """

    world_from_asset: sim3.Matrix4
    iterations: int
    stop_reason: str
    history: list[dict[str, Any]] = field(default_factory=list)
    step_clamps: int = 0
    total_clamps: int = 0
    scale_clips: int = 0
    state: tuple[float, NDArray[np.float64], NDArray[np.float64]] | None = field(default=None, repr=False)


_ANGLE_MARGIN = 1e-6
"""Radians: the trace-based angle decides 'within the clamp' only this far from the bound (its rounding
near a small angle is far below this); closer cases take the exact axis-angle path."""


def clamp_rotation(rot: NDArray[np.float64], max_angle: float) -> tuple[NDArray[np.float64], bool]:
    """Shorten a rotation [3, 3] along its geodesic to at most ``max_angle`` radians; (rotation, clamped)."""
    if sim3.rotation_angle(rot) < max_angle - _ANGLE_MARGIN:  # clearly within: no axis-angle round trip
        return np.asarray(rot, dtype=np.float64), False
    rotvec = Rotation.from_matrix(rot).as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    if angle <= max_angle:
        return np.asarray(rot, dtype=np.float64), False
    return Rotation.from_rotvec(rotvec * (max_angle / angle)).as_matrix(), True


def umeyama(source: NDArray[np.float64], target: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """Closed-form similarity (scale, rotation [3, 3]) minimising |target_c - s R source_c|^2 on centred pairs.

    source, target: float64 [n, 3] paired points. The translation follows from the means.
    """
    src_c = source - source.mean(axis=0)
    tgt_c = target - target.mean(axis=0)
    # Kabsch: the rotation maximising trace(R H) for H = src_c^T tgt_c, reflection excluded.
    u, _, vt = np.linalg.svd(src_c.T @ tgt_c)
    flip = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rot = vt.T @ np.diag([1.0, 1.0, flip]) @ u.T
    denom = float(np.sum(src_c * src_c))
    if denom <= 0:
        raise FloatingPointError("source correspondences collapse to one point")
    scale = float(np.sum((src_c @ rot.T) * tgt_c)) / denom
    if not np.isfinite(scale) or scale <= 0:
        raise FloatingPointError(f"Umeyama scale is {scale!r}")
    return scale, rot


def bounded_sim3_icp(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    init: sim3.Matrix4,
    extent: float,
    config: RegistrationConfig,
    tree: cKDTree | None = None,
    resume: IcpResult | None = None,
) -> IcpResult:
    """Refine ``init`` (world_from_asset) with the bounded Sim(3) ICP.

    source: float64 [n, 3] samples on the asset (asset frame). target: float64 [m, 3] world metres.
    extent: the target's bounding-box diagonal (m), the unit of the rejection distance and tolerance.
    tree: a cKDTree of ``source`` to reuse (built here when None).
    resume: an earlier, shorter run from the same ``init`` with the same bounds (e.g. a probe with fewer
    ``max_iterations``); the refinement continues from its state, so the result is that of one run
    of ``config.max_iterations`` from ``init``. A resumed run that had stopped for another reason than
    its iteration budget is returned unchanged.
    Raises FloatingPointError / Sim3Error on a numerical failure (the caller falls back).
    """
    s0, rot0, _ = sim3.parts_from_sim3(init)
    quat0 = Rotation.from_matrix(rot0)
    scale, rot, trans = sim3.parts_from_sim3(init)
    if tree is None:
        tree = cKDTree(source, leafsize=KD_LEAF_SIZE)
    max_dist = config.max_distance_ratio * extent
    step_max = np.deg2rad(config.max_step_rotation_deg)
    total_max = np.deg2rad(config.max_total_rotation_deg)
    keep_log = 1.0 - config.scale_regularization
    history: list[dict[str, Any]] = []
    step_clamps = total_clamps = scale_clips = 0
    stop = "max_iterations"
    iteration = done = 0
    if resume is not None:
        if resume.stop_reason != "max_iterations" or resume.iterations >= config.max_iterations:
            return resume
        if resume.state is None:
            raise ValueError("the resumed ICP result carries no solver state")
        scale, rot, trans = resume.state
        history = list(resume.history)
        step_clamps, total_clamps, scale_clips = resume.step_clamps, resume.total_clamps, resume.scale_clips
        iteration = done = resume.iterations
    for iteration in range(done + 1, config.max_iterations + 1):
        # Nearest source sample of each target point, queried in the asset frame (tree built once).
        query = ((target - trans) @ rot) / scale
        # Pairs beyond max_dist are rejected below; the search need not look farther (a hair of margin
        # keeps the rejection test below the one authority, so the kept pairs are the same).
        dist, idx = tree.query(query, workers=1, distance_upper_bound=(1.0 + 1e-9) * max_dist / scale)
        dist = dist * scale
        near = dist <= max_dist
        if int(near.sum()) < config.min_correspondences:
            stop = "too_few_correspondences"
            iteration -= 1
            break
        cut = float(np.quantile(dist[near], config.keep_quantile))
        keep = near & (dist <= cut)
        if int(keep.sum()) < config.min_correspondences:
            stop = "too_few_correspondences"
            iteration -= 1
            break
        a, b = source[idx[keep]], target[keep]
        s_u, rot_u = umeyama(a, b)

        step_rot, step_clamped = clamp_rotation(rot_u @ rot.T, step_max)
        step_scale = float(np.exp(keep_log * np.log(s_u / scale)))
        new_scale = scale * step_scale
        clipped = float(np.clip(new_scale, s0 * config.scale_min, s0 * config.scale_max))
        scale_clipped = abs(clipped - new_scale) > 1e-12 * abs(new_scale)  # np.isclose(rtol=1e-12, atol=0)
        ref_rot, total_clamped = clamp_rotation(step_rot @ rot @ rot0.T, total_max)
        # Rebuilt through a quaternion: chained matrix products lose orthonormality, and
        # R_u R^T R then doubles the error every step.
        new_rot = (Rotation.from_matrix(ref_rot) * quat0).as_matrix()
        new_trans = b.mean(axis=0) - clipped * (new_rot @ a.mean(axis=0))

        # Displacement bound of points within the target extent (m): translation + rotation + scale.
        moved = float(
            np.linalg.norm(new_trans - trans)
            + extent * (sim3.rotation_angle(new_rot @ rot.T) + abs(np.log(clipped / scale)))
        )
        step_clamps += int(step_clamped)
        total_clamps += int(total_clamped)
        scale_clips += int(scale_clipped)
        history.append(
            {
                "iteration": iteration,
                "kept": int(keep.sum()),
                "near": int(near.sum()),
                "kept_rmse": float(np.sqrt(np.mean(dist[keep] ** 2))),
                "step_rotation_deg": float(np.rad2deg(sim3.rotation_angle(step_rot))),
                "step_scale": step_scale,
                "step_clamped": step_clamped,
                "total_clamped": total_clamped,
                "scale_clipped": scale_clipped,
            }
        )
        scale, rot, trans = clipped, new_rot, new_trans
        if not (np.isfinite(scale) and np.all(np.isfinite(rot)) and np.all(np.isfinite(trans))):
            raise FloatingPointError("ICP produced a non-finite pose")
        if moved < config.icp_tolerance * extent:
            stop = "converged"
            break
    return IcpResult(
        world_from_asset=sim3.sim3_from_parts(scale, rot, trans),
        iterations=iteration,
        stop_reason=stop,
        history=history,
        step_clamps=step_clamps,
        total_clamps=total_clamps,
        scale_clips=scale_clips,
        state=(scale, rot, trans),
    )
