"""register(): align an asset to its instance point cloud with a gated, bounded Sim(3) (paper Sec. 3.3).

Steps, each recorded in ``Pose.diagnostics`` (``RegistrationDiagnostics``, written to
``instances/<id>/pose.json``):

1. Input checks (``gates.check_inputs``): finite asset vertices with faces, >= ``min_correspondences``
   finite target points, neither cloud planar nor collinear. Failures give ``Missing(stage="registration")``.
2. Source samples on the mesh (seeded), target subsample to ``max_target_points`` and its largest cluster.
3. Initialisation (``candidates``): FPFH + RANSAC on extent-normalised clouds, ``ransac_restarts`` seeded
   runs, each candidate through the initialisation gate (no RMSE worsening and at most
   ``inlier_drop_tolerance`` inlier-ratio drop against the normalisation pose; scale within
   ``max_init_scale_ratio`` of the extent ratio; the rotation gate ``init_rotation_gate_deg``), an
   upright turn for candidates failing only the rotation gate, early exit at
   ``ransac_early_exit_inlier_ratio``; the normalisation pose when none is accepted.
4. Refinement (``refinement``): bounded Sim(3) ICP of the accepted candidates (probe first when several),
   the result gate against the pre-refinement pose, the conservative rigid ICP when the solver fails
   numerically; the best by symmetric fitness (mean of target and source inlier ratios: a symmetric
   object gives several candidates that fit equally, and this prefers the one that neither leaves target
   points uncovered nor overshoots them) wins.
5. A final pose whose inlier ratio is below ``min_result_inlier_ratio`` becomes ``Missing``.

The rotation gates' reference (an orientation prior, or the gravity-up tilt) is described in ``gates``.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from rescene_core.config import RegistrationConfig
from rescene_core.records import Asset, InstancePoints, Missing, Pose, Stage
from rescene_core.registration.candidates import initial_candidates
from rescene_core.registration.diagnostics import CloudSummary, FinalRecord, PoseSummary, RegistrationDiagnostics
from rescene_core.registration.fit import FitEvaluator
from rescene_core.registration.gates import (
    RejectedInput,
    check_inputs,
    degeneracy,
    orientation_prior,
    rotation_gate_angle,
    upright_snap,
)
from rescene_core.registration.init import Normalisation
from rescene_core.registration.refinement import refine_best

STAGE = Stage.REGISTRATION

__all__ = [
    "degeneracy",
    "largest_cluster",
    "prepare_target",
    "register",
    "register_detailed",
    "rotation_gate_angle",
    "upright_snap",
]


def sample_source(asset: Asset, config: RegistrationConfig) -> NDArray[np.float64]:
    """``source_samples`` points [n, 3] (asset frame) on the asset's surface, seeded by ``config.seed``."""

    mesh = trimesh.Trimesh(np.asarray(asset.vertices, np.float64), np.asarray(asset.faces), process=False)
    if not mesh.area > 0:
        raise RejectedInput("asset mesh has zero surface area")
    points, _ = trimesh.sample.sample_surface(mesh, config.source_samples, seed=config.seed)
    return np.asarray(points, dtype=np.float64)


def largest_cluster(points: NDArray[np.float64], config: RegistrationConfig) -> NDArray[np.float64]:
    """The target's largest DBSCAN cluster (radius ``cluster_eps_spacings`` median NN spacings), or all
    points when that cluster has fewer than ``min_correspondences`` points. points: [n, 3] world metres."""
    import open3d as o3d

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


def register(asset: Asset, target: InstancePoints, config: RegistrationConfig | None = None) -> Pose | Missing:
    """Align ``asset`` to ``target``; see ``register_detailed`` (this drops the diagnostics of a Missing)."""
    return register_detailed(asset, target, config)[0]


def register_detailed(
    asset: Asset, target: InstancePoints, config: RegistrationConfig | None = None
) -> tuple[Pose | Missing, RegistrationDiagnostics]:
    """Align ``asset`` (asset frame) to ``target`` (world metres) with the gated, bounded Sim(3) of the paper.

    Returns a Pose whose ``world_from_asset`` maps asset-frame vertices into the world (metres), with
    every gate decision and residual in ``diagnostics`` (``RegistrationDiagnostics.to_json()``); or
    Missing(stage='registration') with the reason when the input is unusable or the final pose fails the
    quality floor; plus the typed diagnostics (also for a Missing, for the run log). Never raises on bad
    input.
    """
    config = config or RegistrationConfig()
    start = time.perf_counter()
    instance = target.instance
    diag = RegistrationDiagnostics(config, asset.backend)
    try:
        points = check_inputs(asset, target, config)
        source = sample_source(asset, config)
    except RejectedInput as err:
        diag.rejected = str(err)
        return Missing(instance, STAGE, f"rejected input: {err}"), diag

    tgt = prepare_target(points, config)
    if len(tgt) < config.min_correspondences:
        diag.rejected = f"{len(tgt)} target points after cleaning"
        return Missing(instance, STAGE, f"rejected input: {diag.rejected}"), diag
    # bounding boxes normalise the clouds for FPFH (the features' scale only); the robust boxes give the
    # normalisation pose, the extent ratio of the scale gate and the extent unit of the ICP distances
    src_norm, tgt_norm = Normalisation.of(source), Normalisation.of(tgt)
    src_box = Normalisation.of(source, config.extent_percentile)
    tgt_box = Normalisation.of(tgt, config.extent_percentile)
    extent = tgt_box.extent
    evaluator = FitEvaluator(source, tgt, config.max_distance_ratio * extent)
    prior = orientation_prior(asset)
    diag.clouds = CloudSummary(
        target_points=len(points),
        target_points_used=len(tgt),
        target_points_dropped_as_stray=int(min(len(points), config.max_target_points) - len(tgt)),
        source_samples=len(source),
        source_normalisation=src_norm,
        target_normalisation=tgt_norm,
        source_robust_box=src_box,
        target_robust_box=tgt_box,
        inlier_threshold_m=evaluator.threshold,
        rotation_gate_reference="prior" if prior is not None else "gravity-up tilt",
    )

    accepted, diag.init, diag.search = initial_candidates(
        source, tgt, evaluator, (src_norm, tgt_norm), (src_box, tgt_box), prior, config
    )
    best, chosen = refine_best(source, tgt, accepted, evaluator, extent, prior, config)
    diag.refinement = best.record
    diag.final = FinalRecord(
        chosen.record.source,
        best.fit,
        PoseSummary.of(best.world_from_asset),
        rotation_gate_angle(best.world_from_asset, prior),
        best.method,
    )
    diag.seconds = time.perf_counter() - start
    if best.fit.inlier_ratio < config.min_result_inlier_ratio:
        reason = f"final inlier ratio {best.fit.inlier_ratio:.3f} < {config.min_result_inlier_ratio} ({best.method})"
        diag.rejected = reason
        return Missing(instance, STAGE, reason), diag
    return Pose(instance, best.world_from_asset, best.method, diag.to_json()), diag
