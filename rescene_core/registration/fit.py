"""Alignment quality of a Sim(3) pose: nearest-neighbour residuals of the target against the posed asset.

Residuals run from each target point to its nearest source sample (target -> source), because the
target is a partial scan of the object while the source samples cover the whole asset: every target
point has a true counterpart on the asset, not the other way round.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from rescene_core.geometry import sim3


@dataclass(frozen=True)
class Fit:
    """Residuals of one pose.

    rmse: nearest-neighbour RMSE (m) over all target points, each distance truncated at the inlier
    threshold so that outliers count but cannot dominate. inlier_ratio: fraction of target points
    within the threshold. source_inlier_ratio: fraction of source samples within the threshold of the
    target (low for a partial target, and lower still for an oversized or misplaced asset).
    """

    rmse: float
    inlier_ratio: float
    source_inlier_ratio: float

    @property
    def symmetric_fitness(self) -> float:
        """Mean of the two inlier ratios: rewards covering the target without overshooting it."""
        return 0.5 * (self.inlier_ratio + self.source_inlier_ratio)

    def to_json(self) -> dict[str, float]:
        return {
            "rmse": float(self.rmse),
            "inlier_ratio": float(self.inlier_ratio),
            "source_inlier_ratio": float(self.source_inlier_ratio),
        }


KD_LEAF_SIZE = 32
"""Leaf size of the registration KD-trees (speed only: the neighbours found are the same)."""


class FitEvaluator:
    """Evaluates poses of fixed source samples (asset frame) against fixed target points (world, m).

    source: float64 [n, 3] asset frame. target: float64 [m, 3] world frame, metres.
    threshold: inlier distance (m) in the world frame.
    """

    def __init__(self, source: NDArray[np.float64], target: NDArray[np.float64], threshold: float):
        self.source = np.asarray(source, dtype=np.float64)
        self.target = np.asarray(target, dtype=np.float64)
        self.threshold = float(threshold)
        # Built once per instance and shared by every fit, the ICP and its probes. Leaves of 32 points
        # answer these 3000-5000-point batch queries faster than the default 16 (same neighbours).
        self.source_tree = cKDTree(self.source, leafsize=KD_LEAF_SIZE)
        self.target_tree = cKDTree(self.target, leafsize=KD_LEAF_SIZE)

    def target_to_source(
        self, world_from_asset: sim3.Matrix4, upper_bound: float = np.inf
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Distance (m, world) and index of the nearest source sample for every target point.

        upper_bound (m, world): points with no source sample within it get distance inf and index
        ``len(source)`` (the search stops there, which is faster).
        """
        scale = sim3.parts_from_sim3(world_from_asset)[0]
        query = sim3.apply(sim3.inverse(world_from_asset), self.target)
        dist, idx = self.source_tree.query(query, workers=1, distance_upper_bound=upper_bound / scale)
        return dist * scale, idx

    def __call__(self, world_from_asset: sim3.Matrix4) -> Fit:
        # Distances beyond the threshold count as the threshold, so the search stops just past it.
        dist, _ = self.target_to_source(world_from_asset, (1.0 + 1e-9) * self.threshold)
        clipped = np.minimum(dist, self.threshold)
        posed = sim3.apply(world_from_asset, self.source)
        back, _ = self.target_tree.query(posed, distance_upper_bound=self.threshold, workers=1)
        return Fit(
            rmse=float(np.sqrt(np.mean(clipped**2))),
            inlier_ratio=float(np.mean(dist <= self.threshold)),
            source_inlier_ratio=float(np.mean(np.isfinite(back))),
        )


def add_s(points_gt: NDArray, points_est: NDArray) -> float:
    """Symmetry-aware surface distance ADD-S (m): mean over ``points_gt`` of the closest ``points_est``."""
    dist, _ = cKDTree(np.asarray(points_est, dtype=np.float64)).query(np.asarray(points_gt, np.float64), workers=1)
    return float(np.mean(dist))
