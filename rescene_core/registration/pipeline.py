"""register(): align an asset to its instance point cloud with a gated, bounded Sim(3) (paper Sec. 3.3).

Steps, each recorded in ``Pose.diagnostics`` (written to ``instances/<id>/pose.json``):

1. Input checks: finite asset vertices with faces, >= ``min_correspondences`` finite target points,
   neither cloud planar nor collinear. Failures give ``Missing(stage="registration")``.
2. Source samples on the mesh (seeded), target subsample to ``max_target_points``.
3. Initialisation: FPFH + RANSAC on extent-normalised clouds, ``ransac_restarts`` seeded runs. Each
   candidate passes the initialisation gate or is rejected (reasons recorded):
   * no RMSE worsening and at most ``inlier_drop_tolerance`` inlier-ratio drop relative to the
     'identity after normalisation' pose;
   * its scale is within ``max_init_scale_ratio`` of the extent ratio (a RANSAC scale far off the
     extent ratio is a wrong match, not a plausible object);
   * the rotation gate ``init_rotation_gate_deg`` (see below).
   A candidate rejected only by the rotation gate is tried once more turned upright (``upright_snap``:
   the smallest rotation about the asset's centre that brings its up axis to world up) and must pass
   every gate itself. The restarts stop early once an accepted candidate reaches
   ``ransac_early_exit_inlier_ratio``.
   The best accepted candidate by symmetric fitness (mean of target and source inlier ratios; a
   symmetric object gives several candidates that fit equally, and this prefers the one that neither
   leaves target points uncovered nor overshoots them) is the initialisation; with none accepted the
   normalisation pose is. With several accepted candidates each first gets a short probe refinement
   (``probe_iterations``) and the best probe is refined fully from its own starting pose.
4. Bounded Sim(3) ICP from the initialisation (``bounded_icp``).
5. Result gate against the pre-refinement pose: no RMSE worsening, inlier drop <= tolerance, scale
   within [s_min, s_max] of the initial scale, refinement rotation <= theta_tot, and the result
   rotation gate. A rejected refinement keeps the pre-refinement pose.
6. A solver failure (exception or invalid output) falls back to Open3D point-to-point rigid ICP at
   the initial scale, which passes the same result gate.
7. A final pose whose inlier ratio is below ``min_result_inlier_ratio`` becomes ``Missing``.

Rotation gates (interpretation). The paper gates the initial and the final rotation at 50 deg without
saying against what. Generated assets come out upright (SAM 3D Objects' canonical frame, and the
``lift`` backend's gravity-up frame): their +z axis is the object's up. The gates therefore measure,
when the asset carries a prior orientation ``metadata["world_from_asset_prior"]`` (e.g. a generator's
layout prediction), the geodesic angle between the candidate's rotation and the prior's; otherwise the
tilt, i.e. the angle between the asset's up axis mapped into the world and world +z. Yaw is free
without a prior, since a single-view generator's frame says nothing about it.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.records import Asset, InstancePoints, Missing, Pose
from rescene_core.registration.bounded_icp import IcpResult, bounded_sim3_icp
from rescene_core.registration.fit import Fit, FitEvaluator
from rescene_core.registration.init import Normalisation, fpfh_ransac_candidates, normalisation_pose

STAGE = "registration"
UP = np.array([0.0, 0.0, 1.0])


class _Rejected(Exception):
    """Bad input: becomes Missing with this reason."""


def degeneracy(points: NDArray[np.float64]) -> tuple[float, float]:
    """(2nd / 1st, 3rd / 1st) principal standard deviations of a cloud [n, 3]: ~0 means collinear / planar."""
    centred = points - points.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[0] <= 0:
        return 0.0, 0.0
    return float(sv[1] / sv[0]), float(sv[2] / sv[0])


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
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(axis / norm * np.arctan2(norm, cos)).as_matrix()
    new_rot = Rotation.from_matrix(turn @ rot).as_matrix()
    pivot = scale * (rot @ asset_pivot) + trans
    return sim3.sim3_from_parts(scale, new_rot, pivot - scale * (new_rot @ asset_pivot))


def _check_inputs(asset: Asset, target: InstancePoints, config: RegistrationConfig) -> NDArray[np.float64]:
    vertices = np.asarray(asset.vertices, dtype=np.float64)
    faces = np.asarray(asset.faces)
    if vertices.ndim != 2 or vertices.shape[1:] != (3,) or len(vertices) < 4:
        raise _Rejected(f"asset has {len(vertices)} vertices of shape {vertices.shape[1:]}; needs >= 4 3D vertices")
    if not np.all(np.isfinite(vertices)):
        raise _Rejected(f"asset has {int((~np.isfinite(vertices)).any(axis=1).sum())} non-finite vertices")
    if faces.ndim != 2 or faces.shape[1:] != (3,) or len(faces) == 0:
        raise _Rejected("asset mesh has no faces")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise _Rejected("asset faces index vertices that do not exist")
    points = np.asarray(target.points, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(points)):
        raise _Rejected(f"target has {int((~np.isfinite(points)).any(axis=1).sum())} non-finite points")
    if len(points) < config.min_correspondences:
        raise _Rejected(f"target has {len(points)} points; needs >= {config.min_correspondences}")
    for name, cloud in (("target", points), ("asset", vertices)):
        line, plane = degeneracy(cloud)
        if line < config.degenerate_ratio:
            raise _Rejected(f"{name} is collinear (spread ratios {line:.2e}, {plane:.2e})")
        if plane < config.degenerate_ratio:
            raise _Rejected(f"{name} is planar (spread ratios {line:.2e}, {plane:.2e})")
    return points


def _sample_source(asset: Asset, config: RegistrationConfig) -> NDArray[np.float64]:
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(asset.vertices, np.float64), np.asarray(asset.faces), process=False)
    if not mesh.area > 0:
        raise _Rejected("asset mesh has zero surface area")
    points, _ = trimesh.sample.sample_surface(mesh, config.source_samples, seed=config.seed)
    return np.asarray(points, dtype=np.float64)


def largest_cluster(points: NDArray[np.float64], config: RegistrationConfig) -> NDArray[np.float64]:
    """The target's largest DBSCAN cluster (radius ``cluster_eps_spacings`` median NN spacings), or all
    points when that cluster has fewer than ``min_correspondences`` points. points: [n, 3] world metres."""
    import open3d as o3d
    from scipy.spatial import cKDTree

    if len(points) < max(config.min_correspondences, 3):
        return points
    dist, _ = cKDTree(points).query(points, k=2, workers=1)
    spacing = float(np.median(dist[:, 1]))
    if not spacing > 0:
        return points
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    labels = np.asarray(
        cloud.cluster_dbscan(eps=config.cluster_eps_spacings * spacing, min_points=config.cluster_min_points)
    )
    if not np.any(labels >= 0):
        return points
    keep = labels == int(np.bincount(labels[labels >= 0]).argmax())
    return points[keep] if int(keep.sum()) >= config.min_correspondences else points


def prepare_target(points: NDArray[np.float64], config: RegistrationConfig) -> NDArray[np.float64]:
    """Subsample to ``max_target_points`` (seeded), then keep the largest cluster."""
    return largest_cluster(_subsample(points, config.max_target_points, config.seed), config)


def _subsample(points: NDArray[np.float64], count: int, seed: int) -> NDArray[np.float64]:
    if len(points) <= count:
        return points
    rng = np.random.default_rng(seed)
    return points[np.sort(rng.choice(len(points), size=count, replace=False))]


def _gate(
    fit: Fit,
    reference: Fit,
    config: RegistrationConfig,
) -> list[str]:
    """Reasons a pose fails the RMSE / inlier gate against a reference fit (empty = passes)."""
    reasons = []
    if fit.rmse > reference.rmse + config.rmse_worsening_tolerance:
        reasons.append(f"rmse {fit.rmse:.4g} > reference {reference.rmse:.4g} + {config.rmse_worsening_tolerance}")
    if fit.inlier_ratio < reference.inlier_ratio - config.inlier_drop_tolerance:
        reasons.append(
            f"inlier ratio {fit.inlier_ratio:.3f} < reference {reference.inlier_ratio:.3f} - {config.inlier_drop_tolerance}"
        )
    return reasons


def _prior(asset: Asset) -> sim3.Matrix4 | None:
    prior = asset.metadata.get("world_from_asset_prior")
    if prior is None:
        return None
    prior = np.asarray(prior, dtype=np.float64)
    return None if sim3.check_sim3(prior, atol=1e-5) else prior


def _pose_json(m: sim3.Matrix4) -> dict[str, Any]:
    s, rot, t = sim3.parts_from_sim3(m)
    return {
        "scale": float(s),
        "rotvec_deg": [float(v) for v in np.rad2deg(sim3.log(m)[3:6])],
        "translation": [float(v) for v in t],
    }


def _result_gate(
    result: sim3.Matrix4,
    init: sim3.Matrix4,
    fit: Fit,
    init_fit: Fit,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
) -> list[str]:
    reasons = _gate(fit, init_fit, config)
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


def _fallback_icp(
    source: NDArray[np.float64], target: NDArray[np.float64], init: sim3.Matrix4, extent: float, config
) -> sim3.Matrix4:
    """Conservative nearest-neighbour ICP: Open3D rigid point-to-point ICP at the initial scale."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(sim3.apply(init, source)))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target))
    result = reg.registration_icp(
        src,
        tgt,
        config.max_distance_ratio * extent,
        np.eye(4),
        reg.TransformationEstimationPointToPoint(False),
        reg.ICPConvergenceCriteria(max_iteration=config.max_iterations),
    )
    return sim3.compose(np.asarray(result.transformation, dtype=np.float64), init)


def register(asset: Asset, target: InstancePoints, config: RegistrationConfig | None = None) -> Pose | Missing:
    """Align ``asset`` to ``target``; see ``register_detailed`` (this drops the diagnostics of a Missing)."""
    return register_detailed(asset, target, config)[0]


def register_detailed(
    asset: Asset, target: InstancePoints, config: RegistrationConfig | None = None
) -> tuple[Pose | Missing, dict[str, Any]]:
    """Align ``asset`` (asset frame) to ``target`` (world metres) with the gated, bounded Sim(3) of the paper.

    Returns a Pose whose ``world_from_asset`` maps asset-frame vertices into the world (metres), with
    every gate decision and residual in ``diagnostics``; or Missing(stage='registration') with the
    reason when the input is unusable or the final pose fails the quality floor; plus the diagnostics
    (also for a Missing, for the run log). Never raises on bad input.
    """
    config = config or RegistrationConfig()
    start = time.perf_counter()
    instance = target.instance
    diag: dict[str, Any] = {"config": config.model_dump(mode="json"), "backend": asset.backend}
    try:
        points = _check_inputs(asset, target, config)
        source = _sample_source(asset, config)
    except _Rejected as err:
        diag["rejected"] = str(err)
        return Missing(instance, STAGE, f"rejected input: {err}"), diag

    tgt = prepare_target(points, config)
    if len(tgt) < config.min_correspondences:
        diag["rejected"] = f"{len(tgt)} target points after cleaning"
        return Missing(instance, STAGE, f"rejected input: {len(tgt)} target points after cleaning"), diag
    # bounding boxes normalise the clouds for FPFH (the features' scale only); the robust boxes give the
    # normalisation pose, the extent ratio of the scale gate and the extent unit of the ICP distances
    src_norm, tgt_norm = Normalisation.of(source), Normalisation.of(tgt)
    src_box = Normalisation.of(source, config.extent_percentile)
    tgt_box = Normalisation.of(tgt, config.extent_percentile)
    extent = tgt_box.extent
    evaluator = FitEvaluator(source, tgt, config.max_distance_ratio * extent)
    prior = _prior(asset)
    diag.update(
        {
            "target_points": len(points),
            "target_points_used": len(tgt),
            "target_points_dropped_as_stray": int(min(len(points), config.max_target_points) - len(tgt)),
            "source_samples": len(source),
            "source_normalisation": src_norm.to_json(),
            "target_normalisation": tgt_norm.to_json(),
            "source_robust_box": src_box.to_json(),
            "target_robust_box": tgt_box.to_json(),
            "inlier_threshold_m": evaluator.threshold,
            "rotation_gate_reference": "prior" if prior is not None else "gravity-up tilt",
        }
    )

    # 1) initialisation candidates, each gated against the normalisation pose
    reference = normalisation_pose(src_box, tgt_box)
    reference_fit = evaluator(reference)
    extent_scale = sim3.parts_from_sim3(reference)[0]
    accepted: list[tuple[sim3.Matrix4, Fit, dict[str, Any]]] = []
    candidates_json: list[dict[str, Any]] = []

    def consider(cand: sim3.Matrix4, name: str) -> list[str]:
        """Gate one candidate against the normalisation pose, record it; returns the reasons it failed."""
        fit = evaluator(cand)
        reasons = _gate(fit, reference_fit, config)
        scale_ratio = sim3.parts_from_sim3(cand)[0] / extent_scale
        if not (1.0 / config.max_init_scale_ratio <= scale_ratio <= config.max_init_scale_ratio):
            reasons.append(
                f"scale {scale_ratio:.3f} x the extent ratio is outside [1/{config.max_init_scale_ratio}, "
                f"{config.max_init_scale_ratio}]"
            )
        gate = rotation_gate_angle(cand, prior)
        if gate > config.init_rotation_gate_deg:
            reasons.append(f"init rotation gate {gate:.1f} deg > {config.init_rotation_gate_deg}")
        duplicate = next((j for j, (other, _, _) in enumerate(accepted) if _same_pose(cand, other, extent)), None)
        record = {
            "source": name,
            "pose": _pose_json(cand),
            "fit": fit.to_json(),
            "scale_vs_extent_ratio": float(scale_ratio),
            "rotation_gate_deg": gate,
            "accepted": not reasons,
            "reasons": reasons,
            "duplicate_of": duplicate,
        }
        candidates_json.append(record)
        if not reasons and duplicate is None:
            accepted.append((cand, fit, record))
        return reasons

    processed = 0

    def process(cand: sim3.Matrix4) -> bool:
        """Gate a RANSAC candidate (and its upright turn); True once one accepted fits well enough to stop."""
        nonlocal processed
        k = processed
        processed += 1
        reasons = consider(cand, f"fpfh_ransac[{k}]")
        only_tilt = bool(reasons) and all(r.startswith("init rotation gate") for r in reasons)
        if config.upright_snap and prior is None and only_tilt:
            snapped = upright_snap(cand, src_box.centre)
            if snapped is not None:
                consider(snapped, f"fpfh_ransac[{k}]+upright")
        return any(fit.inlier_ratio >= config.ransac_early_exit_inlier_ratio for _, fit, _ in accepted)

    seeds: list[int] = []
    try:
        candidates = fpfh_ransac_candidates(source, tgt, src_norm, tgt_norm, config, stop=process, seeds=seeds)
        diag["ransac_error"] = None
    except Exception as err:  # an Open3D failure leaves the normalisation pose as initialisation
        candidates = []
        diag["ransac_error"] = f"{type(err).__name__}: {err}"
    for cand in candidates[processed:]:  # candidates not yet seen by the stop callback
        process(cand)
    diag["ransac_restarts_run"] = processed
    # every random draw is seeded: source samples and target subsample by config.seed (numpy), RANSAC
    # restart r by config.seed + r (Open3D's engine, held under a process-wide lock while it draws)
    diag["seeds"] = {"sampling": int(config.seed), "ransac": seeds}
    if not accepted:
        record = {"source": "normalisation", "pose": _pose_json(reference), "fit": reference_fit.to_json()}
        candidates_json.append(record)
        accepted.append((reference, reference_fit, record))
    diag["init"] = {"reference_fit": reference_fit.to_json(), "candidates": candidates_json}

    # 2) bounded refinement of the accepted candidates; the best gated result by symmetric fitness wins.
    # With several candidates each first gets a short probe refinement (probe_iterations); only the best
    # probe is refined with the full budget, from its own initialisation (same bounds as a direct run):
    # the full run continues the probe's ICP where it stopped, which is the same computation.
    best: tuple[tuple[float, float], sim3.Matrix4, Fit, str, dict[str, Any], dict[str, Any]] | None = None
    probing = len(accepted) > 1 and 0 < config.probe_iterations < config.max_iterations
    finalists: list[tuple[sim3.Matrix4, Fit, dict[str, Any], IcpResult | None]]
    if probing:
        probe_config = config.model_copy(update={"max_iterations": config.probe_iterations})
        probes = []
        probe_runs: list[IcpResult | None] = []
        for init, init_fit, record in accepted:
            _, probe_fit, _, _, probe_run = _refine(source, tgt, init, init_fit, evaluator, extent, prior, probe_config)
            record["probe_fit"] = probe_fit.to_json()
            probes.append((probe_fit.symmetric_fitness, -probe_fit.rmse))
            probe_runs.append(probe_run)
        winner = int(max(range(len(probes)), key=probes.__getitem__))
        finalists = [(*accepted[winner], probe_runs[winner])]
    else:
        finalists = [(*candidate, None) for candidate in accepted]
    for init, init_fit, record, resume in finalists:
        final, final_fit, method, refinement, _ = _refine(
            source, tgt, init, init_fit, evaluator, extent, prior, config, resume
        )
        record["refined_fit"] = final_fit.to_json()
        record["method"] = method
        key = (final_fit.symmetric_fitness, -final_fit.rmse)
        if best is None or key > best[0]:
            best = (key, final, final_fit, method, refinement, record)
    assert best is not None
    _, final, final_fit, method, refinement, chosen = best
    chosen["chosen"] = True
    diag["refinement"] = refinement
    diag["final"] = {
        "init": chosen["source"],
        "fit": final_fit.to_json(),
        "symmetric_fitness": final_fit.symmetric_fitness,
        "pose": _pose_json(final),
        "rotation_gate_deg": rotation_gate_angle(final, prior),
        "method": method,
    }
    diag["rmse"] = final_fit.rmse
    diag["inlier_ratio"] = final_fit.inlier_ratio
    diag["seconds"] = time.perf_counter() - start
    if final_fit.inlier_ratio < config.min_result_inlier_ratio:
        reason = f"final inlier ratio {final_fit.inlier_ratio:.3f} < {config.min_result_inlier_ratio} ({method})"
        diag["rejected"] = reason
        return Missing(instance, STAGE, reason), diag
    return Pose(instance, final, method, diag), diag


def _same_pose(a: sim3.Matrix4, b: sim3.Matrix4, extent: float) -> bool:
    """Two candidates within 5 deg, 2 % scale and 2 % of the extent of each other refine alike."""
    sa, ra, ta = sim3.parts_from_sim3(a)
    sb, rb, tb = sim3.parts_from_sim3(b)
    return (
        sim3.rotation_angle(ra @ rb.T) < np.deg2rad(5.0)
        and abs(np.log(sa / sb)) < 0.02
        and float(np.linalg.norm(ta - tb)) < 0.02 * extent
    )


def _refine(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    init: sim3.Matrix4,
    init_fit: Fit,
    evaluator: FitEvaluator,
    extent: float,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
    resume: IcpResult | None = None,
) -> tuple[sim3.Matrix4, Fit, str, dict[str, Any], IcpResult | None]:
    """Bounded ICP from ``init``, gated; a solver failure falls back to the conservative rigid ICP.

    ``resume``: a shorter bounded ICP run from the same ``init`` to continue (see ``bounded_sim3_icp``).
    Returns (pose, fit, method, diagnostics, the bounded ICP run or None when it failed); the pose is
    ``init`` when the refinement is rejected.
    """
    method = "bounded_sim3_icp"
    refined: sim3.Matrix4 | None = None
    out: dict[str, Any] = {}
    result: IcpResult | None = None
    try:
        result = bounded_sim3_icp(source, target, init, extent, config, tree=evaluator.source_tree, resume=resume)
        problems = sim3.check_sim3(result.world_from_asset, atol=1e-6)
        if problems:
            raise FloatingPointError(f"invalid ICP output: {problems}")
        refined = result.world_from_asset
        out = {
            "iterations": result.iterations,
            "stop_reason": result.stop_reason,
            "step_clamps": result.step_clamps,
            "total_clamps": result.total_clamps,
            "scale_clips": result.scale_clips,
            "history": result.history,
            "error": None,
        }
    except Exception as err:
        result = None
        out = {"error": f"{type(err).__name__}: {err}"}
        method = "fallback_nn_icp"
        try:
            refined = _fallback_icp(source, target, init, extent, config)
            problems = sim3.check_sim3(refined, atol=1e-6)
            if problems:
                raise FloatingPointError(f"invalid fallback ICP output: {problems}") from None
        except Exception as err2:
            out["fallback_error"] = f"{type(err2).__name__}: {err2}"
            refined = None
    if refined is None:
        out.update({"accepted": False, "reasons": ["no refinement produced"]})
        return init, init_fit, "init_only", out, None
    refined_fit = evaluator(refined)
    reasons = _result_gate(refined, init, refined_fit, init_fit, prior, config)
    s0, rot0, _ = sim3.parts_from_sim3(init)
    s_r, rot_r, _ = sim3.parts_from_sim3(refined)
    out.update(
        {
            "method": method,
            "init_fit": init_fit.to_json(),
            "fit": refined_fit.to_json(),
            "pose": _pose_json(refined),
            "scale_vs_init": float(s_r / s0),
            "refinement_rotation_deg": float(np.rad2deg(sim3.rotation_angle(rot_r @ rot0.T))),
            "accepted": not reasons,
            "reasons": reasons,
        }
    )
    if reasons:
        return init, init_fit, "init_only", out, result
    return refined, refined_fit, method, out, result
