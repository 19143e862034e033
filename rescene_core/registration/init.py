"""FPFH + RANSAC initialisation on extent-normalised clouds (paper Appendix 'Registration Details').

FPFH descriptors are not scale-invariant and the asset (unit box) and the target (metres) differ in
scale by an unknown factor. Both clouds are therefore centred on the centre of their robust box
(per-axis ``extent_percentile`` to 100 minus it: stray points do not stretch it) and divided by its
diagonal before voxel downsampling, normals, FPFH and RANSAC; the candidate is
then mapped back, which is how the global scale is recovered:

    world_from_asset = world_from_tn * tn_from_sn * sn_from_asset

with ``sn_from_asset`` / ``tn_from_world`` the two normalisations and ``tn_from_sn`` the RANSAC
similarity (Open3D point-to-point estimation with scaling). The normalisation alone (``tn_from_sn`` =
identity) is the reference pose the initialisation gate compares against.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.geometry.open3d_rng import seeded_open3d_rng


@dataclass(frozen=True)
class Normalisation:
    """``normalised_from_frame``: x -> (x - centre) / extent. centre [3] and extent (the diagonal of the
    cloud's box, see ``of``) in frame units."""

    centre: NDArray[np.float64]
    extent: float

    @classmethod
    def of(cls, points: NDArray, percentile: float = 0.0) -> Normalisation:
        """Normalisation of a cloud [n, 3]: its box from the per-axis ``percentile`` and 100 - ``percentile``
        (0: the bounding box). A few percent of stray points (mask bleed fused into an instance cloud)
        stretch the bounding box, and with it the scale of the normalisation pose, by 10-30 %; the
        percentile box ignores them. A robust extent is not the cloud's full extent, hence the same
        percentile for the source and the target, so that their ratio stays a size ratio."""
        if percentile > 0:
            lo, hi = np.percentile(points, [percentile, 100.0 - percentile], axis=0)
        else:
            lo, hi = points.min(axis=0), points.max(axis=0)
        return cls(0.5 * (lo + hi), float(np.linalg.norm(hi - lo)))

    @property
    def normalised_from_frame(self) -> sim3.Matrix4:
        return sim3.sim3_from_parts(1.0 / self.extent, np.eye(3), -self.centre / self.extent)

    @property
    def frame_from_normalised(self) -> sim3.Matrix4:
        return sim3.sim3_from_parts(self.extent, np.eye(3), self.centre)

    def to_json(self) -> dict[str, object]:
        return {"centre": [float(v) for v in self.centre], "extent": float(self.extent)}


def normalisation_pose(source_norm: Normalisation, target_norm: Normalisation) -> sim3.Matrix4:
    """world_from_asset of 'identity after normalisation': bbox centres and diagonals matched, no rotation."""
    return sim3.compose(target_norm.frame_from_normalised, source_norm.normalised_from_frame)


def _prepare(points: NDArray[np.float64], voxel: float, config: RegistrationConfig):
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    down = cloud.voxel_down_sample(voxel)
    down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=config.normal_radius_voxels * voxel, max_nn=30))
    feature = o3d.pipelines.registration.compute_fpfh_feature(  # type: ignore[call-arg]  # Open3D stub omits indices=[] (all points)
        down, o3d.geometry.KDTreeSearchParamHybrid(radius=config.feature_radius_voxels * voxel, max_nn=100)
    )
    return down, feature


def feature_correspondences(source_feature, target_feature) -> NDArray[np.int32]:
    """FPFH matches (source index, target index) int32 [k, 2], once per instance instead of per restart.

    Open3D's own matcher with the mutual filter, as ``registration_ransac_based_on_feature_matching``
    calls it (``correspondences_from_features``: nearest target feature of every source feature, kept
    when mutual; all of them when fewer than 10 % of the source points have a mutual match), so the
    restarts on these matches give the same candidates as feature-matching RANSAC, bit for bit.
    """
    import open3d as o3d

    match = o3d.pipelines.registration.correspondences_from_features(source_feature, target_feature, True)
    return np.asarray(match, dtype=np.int32).reshape(-1, 2)


def ransac_seed(config: RegistrationConfig, restart: int) -> int:
    """Seed of Open3D's random engine for RANSAC restart ``restart`` (0-based): ``config.seed + restart``."""
    return int(config.seed) + int(restart)


def fpfh_ransac_candidates(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    source_norm: Normalisation,
    target_norm: Normalisation,
    config: RegistrationConfig,
    stop: Callable[[sim3.Matrix4], bool] | None = None,
    seeds: list[int] | None = None,
) -> list[sim3.Matrix4]:
    """One world_from_asset candidate per RANSAC restart (restart r uses seed ``ransac_seed(config, r)``,
    drawn under ``seeded_open3d_rng``, so concurrent registrations in other threads cannot change it).

    ``stop``, when given, sees each valid candidate as soon as its restart ends; returning True skips
    the remaining restarts (early exit once a candidate is clearly good). The features and their mutual
    matches are computed once and shared by the restarts. ``seeds``, when given, receives the seed of
    every restart that ran (for the diagnostics).

    source: float64 [n, 3] asset frame; target: float64 [m, 3] world metres. Invalid candidates
    (not a similarity with positive scale) are dropped here.
    """
    import open3d as o3d

    reg = o3d.pipelines.registration
    voxel = config.voxel_ratio  # the normalised clouds have unit diagonal
    src_n = sim3.apply(source_norm.normalised_from_frame, source)
    tgt_n = sim3.apply(target_norm.normalised_from_frame, target)
    src_down, src_feat = _prepare(src_n, voxel, config)
    tgt_down, tgt_feat = _prepare(tgt_n, voxel, config)
    distance = config.ransac_distance_voxels * voxel
    ransac_n = 3
    corres = o3d.utility.Vector2iVector(feature_correspondences(src_feat, tgt_feat))
    out: list[sim3.Matrix4] = []
    for restart in range(config.ransac_restarts):
        # Open3D's random engine is one per process and RANSAC releases the GIL: seeding and drawing
        # happen under a process-wide lock so concurrent registrations cannot reseed or share the stream.
        with seeded_open3d_rng(ransac_seed(config, restart)) as seed:
            if seeds is not None:
                seeds.append(seed)
            result = reg.registration_ransac_based_on_correspondence(
                src_down,
                tgt_down,
                corres,
                distance,
                reg.TransformationEstimationPointToPoint(True),
                ransac_n,
                [
                    reg.CorrespondenceCheckerBasedOnEdgeLength(config.ransac_edge_length),
                    reg.CorrespondenceCheckerBasedOnDistance(distance),
                ],
                reg.RANSACConvergenceCriteria(config.ransac_iterations, config.ransac_confidence),
            )
        tn_from_sn = np.asarray(result.transformation, dtype=np.float64)
        if sim3.check_sim3(tn_from_sn, atol=1e-5):
            continue
        cand = sim3.compose(
            target_norm.frame_from_normalised, sim3.compose(tn_from_sn, source_norm.normalised_from_frame)
        )
        out.append(cand)
        if stop is not None and stop(cand):
            break
    return out
