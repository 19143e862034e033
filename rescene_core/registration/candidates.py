"""Initialisation candidates of registration: FPFH + RANSAC restarts, each through the initialisation gate.

Each RANSAC candidate passes the initialisation gate (``gates.init_gate``) or is rejected with its reasons.
A candidate rejected only by the rotation gate is tried once more turned upright (``upright_snap``) and
must pass every gate itself. The restarts stop early once an accepted candidate reaches
``ransac_early_exit_inlier_ratio``. With none accepted, the normalisation pose is the initialisation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.registration.diagnostics import (
    CandidateGate,
    CandidateRecord,
    InitRecord,
    PoseSummary,
    SearchRecord,
)
from rescene_core.registration.fit import Fit, FitEvaluator
from rescene_core.registration.gates import init_gate, is_only_tilt, upright_snap
from rescene_core.registration.init import Normalisation, fpfh_ransac_candidates, normalisation_pose


@dataclass(frozen=True)
class Candidate:
    """An accepted initialisation: world_from_asset, its fit and its diagnostics record."""

    world_from_asset: sim3.Matrix4
    fit: Fit
    record: CandidateRecord


def same_pose(a: sim3.Matrix4, b: sim3.Matrix4, extent: float) -> bool:
    """Two candidates within 5 deg, 2 % scale and 2 % of the extent of each other refine alike."""
    sa, ra, ta = sim3.parts_from_sim3(a)
    sb, rb, tb = sim3.parts_from_sim3(b)
    return (
        sim3.rotation_angle(ra @ rb.T) < np.deg2rad(5.0)
        and abs(np.log(sa / sb)) < 0.02
        and float(np.linalg.norm(ta - tb)) < 0.02 * extent
    )


@dataclass
class CandidateSearch:
    """Gates RANSAC candidates against the normalisation pose and keeps the accepted, distinct ones.

    evaluator: fits poses of the source samples to the target. reference / reference_fit: the
    normalisation pose and its fit. extent: the target's robust extent (m). pivot: the source box centre
    (asset frame) an upright turn rotates about. prior: the orientation prior, if any.
    """

    evaluator: FitEvaluator
    reference: sim3.Matrix4
    reference_fit: Fit
    extent: float
    pivot: NDArray[np.float64]
    prior: sim3.Matrix4 | None
    config: RegistrationConfig
    accepted: list[Candidate] = field(default_factory=list)
    records: list[CandidateRecord] = field(default_factory=list)
    processed: int = 0

    def consider(self, candidate: sim3.Matrix4, name: str) -> list[str]:
        """Gate one candidate, record it; returns the reasons it failed."""
        fit = self.evaluator(candidate)
        extent_scale = sim3.parts_from_sim3(self.reference)[0]
        reasons, scale_ratio, gate = init_gate(
            candidate, fit, self.reference_fit, extent_scale, self.prior, self.config
        )
        duplicate = next(
            (j for j, other in enumerate(self.accepted) if same_pose(candidate, other.world_from_asset, self.extent)),
            None,
        )
        record = CandidateRecord(
            name, PoseSummary.of(candidate), fit, CandidateGate(scale_ratio, gate, tuple(reasons), duplicate)
        )
        self.records.append(record)
        if not reasons and duplicate is None:
            self.accepted.append(Candidate(candidate, fit, record))
        return reasons

    def process(self, candidate: sim3.Matrix4) -> bool:
        """Gate a RANSAC candidate (and its upright turn); True once one accepted fits well enough to stop."""
        k = self.processed
        self.processed += 1
        reasons = self.consider(candidate, f"fpfh_ransac[{k}]")
        if self.config.upright_snap and self.prior is None and is_only_tilt(reasons):
            snapped = upright_snap(candidate, self.pivot)
            if snapped is not None:
                self.consider(snapped, f"fpfh_ransac[{k}]+upright")
        return any(c.fit.inlier_ratio >= self.config.ransac_early_exit_inlier_ratio for c in self.accepted)

    def fall_back_to_reference(self) -> None:
        """With no candidate accepted, the normalisation pose is the (only) initialisation."""
        if not self.accepted:
            record = CandidateRecord("normalisation", PoseSummary.of(self.reference), self.reference_fit)
            self.records.append(record)
            self.accepted.append(Candidate(self.reference, self.reference_fit, record))


def initial_candidates(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    evaluator: FitEvaluator,
    normalisations: tuple[Normalisation, Normalisation],
    robust_boxes: tuple[Normalisation, Normalisation],
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
) -> tuple[list[Candidate], InitRecord, SearchRecord]:
    """The accepted initialisations (at least one), the initialisation record and the RANSAC search record.

    source: float64 [n, 3] asset-frame samples; target: float64 [m, 3] cleaned world points (m).
    normalisations: bounding-box normalisations (source, target) for FPFH; robust_boxes: robust boxes
    (source, target) giving the normalisation pose and the extent unit.
    """
    src_box, tgt_box = robust_boxes
    reference = normalisation_pose(src_box, tgt_box)
    search = CandidateSearch(evaluator, reference, evaluator(reference), tgt_box.extent, src_box.centre, prior, config)
    seeds: list[int] = []
    error = None
    try:
        candidates = fpfh_ransac_candidates(source, target, *normalisations, config, stop=search.process, seeds=seeds)
    except RuntimeError as err:  # an Open3D failure leaves the normalisation pose as initialisation
        candidates = []
        error = f"{type(err).__name__}: {err}"
    for candidate in candidates[search.processed :]:  # candidates not yet seen by the stop callback
        search.process(candidate)
    # every random draw is seeded: source samples and target subsample by config.seed (numpy), RANSAC
    # restart r by config.seed + r (Open3D's engine, held under a process-wide lock while it draws)
    record = SearchRecord(error, search.processed, int(config.seed), seeds)
    search.fall_back_to_reference()
    return search.accepted, InitRecord(search.reference_fit, search.records), record
