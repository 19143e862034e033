"""The gates of registration (paper Sec. 3.3): input checks, the fit gate, the rotation gates, the result gate.

Rotation gates (interpretation). The paper gates the initial and the final rotation at 50 deg without
saying against what. Generated assets come out upright (SAM 3D Objects' canonical frame, and the
``lift`` backend's gravity-up frame): their +z axis is the object's up. The gates therefore measure,
when the asset carries a prior orientation ``metadata["world_from_asset_prior"]`` (e.g. a generator's
layout prediction), the geodesic angle between the candidate's rotation and the prior's; otherwise the
tilt, i.e. the angle between the asset's up axis mapped into the world and world +z. Yaw is free
without a prior, since a single-view generator's frame says nothing about it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.records import Asset, InstancePoints
from rescene_core.registration.fit import Fit

UP = np.array([0.0, 0.0, 1.0])


class RejectedInput(Exception):
    """Unusable input: becomes Missing(stage='registration') with this reason."""


def degeneracy(points: NDArray[np.float64]) -> tuple[float, float]:
    """(2nd / 1st, 3rd / 1st) principal standard deviations of a cloud [n, 3]: ~0 means collinear / planar."""
    centred = points - points.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[0] <= 0:
        return 0.0, 0.0
    return float(sv[1] / sv[0]), float(sv[2] / sv[0])


def check_inputs(asset: Asset, target: InstancePoints, config: RegistrationConfig) -> NDArray[np.float64]:
    """The target points [n, 3] (float64) once the asset mesh and the target pass the input checks: finite
    vertices with valid faces, >= ``min_correspondences`` finite target points, neither cloud planar or
    collinear. Raises RejectedInput otherwise."""
    vertices = np.asarray(asset.vertices, dtype=np.float64)
    faces = np.asarray(asset.faces)
    if vertices.ndim != 2 or vertices.shape[1:] != (3,) or len(vertices) < 4:
        raise RejectedInput(f"asset has {len(vertices)} vertices of shape {vertices.shape[1:]}; needs >= 4 3D vertices")
    if not np.all(np.isfinite(vertices)):
        raise RejectedInput(f"asset has {int((~np.isfinite(vertices)).any(axis=1).sum())} non-finite vertices")
    if faces.ndim != 2 or faces.shape[1:] != (3,) or len(faces) == 0:
        raise RejectedInput("asset mesh has no faces")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise RejectedInput("asset faces index vertices that do not exist")
    points = np.asarray(target.points, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(points)):
        raise RejectedInput(f"target has {int((~np.isfinite(points)).any(axis=1).sum())} non-finite points")
    if len(points) < config.min_correspondences:
        raise RejectedInput(f"target has {len(points)} points; needs >= {config.min_correspondences}")
    for name, cloud in (("target", points), ("asset", vertices)):
        line, plane = degeneracy(cloud)
        if line < config.degenerate_ratio:
            raise RejectedInput(f"{name} is collinear (spread ratios {line:.2e}, {plane:.2e})")
        if plane < config.degenerate_ratio:
            raise RejectedInput(f"{name} is planar (spread ratios {line:.2e}, {plane:.2e})")
    return points


def orientation_prior(asset: Asset) -> sim3.Matrix4 | None:
    """The asset's prior world_from_asset (``metadata["world_from_asset_prior"]``) when it is a valid Sim(3)."""
    prior = asset.metadata.get("world_from_asset_prior")
    if prior is None:
        return None
    prior = np.asarray(prior, dtype=np.float64)
    return None if sim3.check_sim3(prior, atol=1e-5) else prior


def rotation_gate_angle(world_from_asset: sim3.Matrix4, prior: sim3.Matrix4 | None) -> float:
    """Gate angle (deg): geodesic distance to the prior's rotation, or the asset-up tilt from world +z."""
    _, rot, _ = sim3.parts_from_sim3(world_from_asset)
    if prior is not None:
        _, rot_prior, _ = sim3.parts_from_sim3(prior)
        return float(np.rad2deg(sim3.rotation_angle(rot @ rot_prior.T)))
    return float(np.rad2deg(np.arccos(np.clip(float(rot[:, 2] @ UP), -1.0, 1.0))))


def upright_snap(world_from_asset: sim3.Matrix4, asset_pivot: NDArray[np.float64]) -> sim3.Matrix4 | None:
    """The pose turned by the smallest rotation that maps the asset's up axis (+z) onto world +z.

    The turn is about the posed ``asset_pivot`` (asset frame, e.g. its bounding-box centre), so the asset
    stays where it was; scale is unchanged. For a flat or rotationally symmetric object whose in-plane
    rotation RANSAC got wrong, the asset's up axis lies in the object's plane and the turn is about the
    plane's normal: the object keeps its fit and becomes upright. None when the up axis is exactly
    upside down (the turn axis is undefined).
    """
    scale, rot, trans = sim3.parts_from_sim3(world_from_asset)
    up = rot[:, 2]
    axis = np.cross(up, UP)
    norm = float(np.linalg.norm(axis))
    cos = float(np.clip(up @ UP, -1.0, 1.0))
    if norm < 1e-9:
        return None if cos < 0 else world_from_asset

    turn = Rotation.from_rotvec(axis / norm * np.arctan2(norm, cos)).as_matrix()
    new_rot = Rotation.from_matrix(turn @ rot).as_matrix()
    pivot = scale * (rot @ asset_pivot) + trans
    return sim3.sim3_from_parts(scale, new_rot, pivot - scale * (new_rot @ asset_pivot))


def fit_gate(fit: Fit, reference: Fit, config: RegistrationConfig) -> list[str]:
    """Reasons a pose fails the RMSE / inlier gate against a reference fit (empty = passes)."""
    reasons = []
    if fit.rmse > reference.rmse + config.rmse_worsening_tolerance:
        reasons.append(f"rmse {fit.rmse:.4g} > reference {reference.rmse:.4g} + {config.rmse_worsening_tolerance}")
    if fit.inlier_ratio < reference.inlier_ratio - config.inlier_drop_tolerance:
        reasons.append(
            f"inlier ratio {fit.inlier_ratio:.3f} < reference {reference.inlier_ratio:.3f} - {config.inlier_drop_tolerance}"
        )
    return reasons


def init_gate(
    candidate: sim3.Matrix4,
    fit: Fit,
    reference_fit: Fit,
    extent_scale: float,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
) -> tuple[list[str], float, float]:
    """The initialisation gate: the fit gate against the normalisation pose, the scale within
    ``max_init_scale_ratio`` of the extent ratio, the rotation gate ``init_rotation_gate_deg``.
    Returns (reasons it fails, scale / extent-ratio scale, rotation gate angle in deg)."""
    reasons = fit_gate(fit, reference_fit, config)
    scale_ratio = sim3.parts_from_sim3(candidate)[0] / extent_scale
    if not (1.0 / config.max_init_scale_ratio <= scale_ratio <= config.max_init_scale_ratio):
        reasons.append(
            f"scale {scale_ratio:.3f} x the extent ratio is outside [1/{config.max_init_scale_ratio}, "
            f"{config.max_init_scale_ratio}]"
        )
    gate = rotation_gate_angle(candidate, prior)
    if gate > config.init_rotation_gate_deg:
        reasons.append(f"init rotation gate {gate:.1f} deg > {config.init_rotation_gate_deg}")
    return reasons, scale_ratio, gate


def is_only_tilt(reasons: list[str]) -> bool:
    """Whether the rotation gate is the only reason a candidate failed (then an upright turn may pass)."""
    return bool(reasons) and all(r.startswith("init rotation gate") for r in reasons)


def result_gate(
    result: sim3.Matrix4,
    init: sim3.Matrix4,
    fit: Fit,
    init_fit: Fit,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
) -> list[str]:
    """The result gate against the pre-refinement pose: the fit gate, the refinement scale within
    [s_min, s_max], the refinement rotation <= theta_tot and the result rotation gate."""
    reasons = fit_gate(fit, init_fit, config)
    s0, rot0, _ = sim3.parts_from_sim3(init)
    s, rot, _ = sim3.parts_from_sim3(result)
    ratio = s / s0
    eps = 1e-9
    if not (config.scale_min - eps <= ratio <= config.scale_max + eps):
        reasons.append(f"refinement scale {ratio:.4f} outside [{config.scale_min}, {config.scale_max}]")
    total = float(np.rad2deg(sim3.rotation_angle(rot @ rot0.T)))
    if total > config.max_total_rotation_deg + 1e-6:
        reasons.append(f"refinement rotation {total:.2f} deg > {config.max_total_rotation_deg}")
    gate = rotation_gate_angle(result, prior)
    if gate > config.result_rotation_gate_deg:
        reasons.append(f"result rotation gate {gate:.1f} deg > {config.result_rotation_gate_deg}")
    return reasons
