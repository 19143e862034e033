"""Typed record of one registration's decisions, written to ``instances/<id>/pose.json`` as ``diagnostics``.

``RegistrationDiagnostics.to_json()`` gives the JSON the run log and pose.json hold; its keys and their
order are the file's contract (tests and caches compare it), so new fields go at the end of a record.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.registration.fit import Fit
from rescene_core.registration.init import Normalisation


@dataclass(frozen=True)
class PoseSummary:
    """A Sim(3) world_from_asset in readable parts: scale, rotation vector (deg) [3], translation (m) [3]."""

    scale: float
    rotvec_deg: tuple[float, ...]
    translation: tuple[float, ...]

    @classmethod
    def of(cls, world_from_asset: sim3.Matrix4) -> PoseSummary:
        scale, _, trans = sim3.parts_from_sim3(world_from_asset)
        rotvec = np.rad2deg(sim3.log(world_from_asset)[3:6])
        return cls(float(scale), tuple(float(v) for v in rotvec), tuple(float(v) for v in trans))

    def to_json(self) -> dict[str, Any]:
        return {"scale": self.scale, "rotvec_deg": list(self.rotvec_deg), "translation": list(self.translation)}


@dataclass(frozen=True)
class CandidateGate:
    """The initialisation gate's verdict on one candidate (the normalisation pose is not gated).

    scale_vs_extent_ratio: candidate scale / extent-ratio scale. rotation_gate_deg: the rotation gate
    angle (deg). reasons: why it failed (empty = accepted). duplicate_of: index of an accepted candidate
    it repeats (then it is not refined again), or None.
    """

    scale_vs_extent_ratio: float
    rotation_gate_deg: float
    reasons: tuple[str, ...]
    duplicate_of: int | None

    @property
    def accepted(self) -> bool:
        return not self.reasons


@dataclass
class CandidateRecord:
    """One initialisation candidate: where it came from (``fpfh_ransac[k]``, ``fpfh_ransac[k]+upright`` or
    ``normalisation``), its pose and fit, the gate's verdict, and what refining it gave."""

    source: str
    pose: PoseSummary
    fit: Fit
    gate: CandidateGate | None = None
    probe_fit: Fit | None = None
    """Fit after the short probe refinement (only when several candidates were accepted)."""
    refined_fit: Fit | None = None
    method: str | None = None
    chosen: bool = False

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"source": self.source, "pose": self.pose.to_json(), "fit": self.fit.to_json()}
        if self.gate is not None:
            out.update(
                {
                    "scale_vs_extent_ratio": float(self.gate.scale_vs_extent_ratio),
                    "rotation_gate_deg": self.gate.rotation_gate_deg,
                    "accepted": self.gate.accepted,
                    "reasons": list(self.gate.reasons),
                    "duplicate_of": self.gate.duplicate_of,
                }
            )
        if self.probe_fit is not None:
            out["probe_fit"] = self.probe_fit.to_json()
        if self.refined_fit is not None:
            out["refined_fit"] = self.refined_fit.to_json()
        if self.method is not None:
            out["method"] = self.method
        if self.chosen:
            out["chosen"] = True
        return out


@dataclass(frozen=True)
class InitRecord:
    """The initialisation: the normalisation pose's fit (the gate's reference) and every candidate."""

    reference_fit: Fit
    candidates: list[CandidateRecord]

    def to_json(self) -> dict[str, Any]:
        return {"reference_fit": self.reference_fit.to_json(), "candidates": [c.to_json() for c in self.candidates]}


@dataclass(frozen=True)
class SolverRun:
    """What the bounded ICP did: iterations, why it stopped, how often each bound was active, per-step history."""

    iterations: int
    stop_reason: str
    step_clamps: int
    total_clamps: int
    scale_clips: int
    history: list[dict[str, Any]]


@dataclass(frozen=True)
class RefinedPose:
    """A refinement's result against its initialisation (before the result gate decides)."""

    method: str
    init_fit: Fit
    fit: Fit
    pose: PoseSummary
    scale_vs_init: float
    refinement_rotation_deg: float


@dataclass(frozen=True)
class RefinementRecord:
    """One refinement: the bounded ICP run (None when it failed, with ``error``), the fallback's failure if
    it failed too, the refined pose (None when no refinement was produced) and the result gate's reasons
    (empty = accepted)."""

    solver: SolverRun | None
    error: str | None
    fallback_error: str | None
    refined: RefinedPose | None
    reasons: tuple[str, ...]

    @property
    def accepted(self) -> bool:
        return self.refined is not None and not self.reasons

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.solver is not None:
            out.update(
                {
                    "iterations": self.solver.iterations,
                    "stop_reason": self.solver.stop_reason,
                    "step_clamps": self.solver.step_clamps,
                    "total_clamps": self.solver.total_clamps,
                    "scale_clips": self.solver.scale_clips,
                    "history": self.solver.history,
                }
            )
        out["error"] = self.error
        if self.fallback_error is not None:
            out["fallback_error"] = self.fallback_error
        if self.refined is not None:
            r = self.refined
            out.update(
                {
                    "method": r.method,
                    "init_fit": r.init_fit.to_json(),
                    "fit": r.fit.to_json(),
                    "pose": r.pose.to_json(),
                    "scale_vs_init": float(r.scale_vs_init),
                    "refinement_rotation_deg": float(r.refinement_rotation_deg),
                }
            )
        out.update({"accepted": self.accepted, "reasons": list(self.reasons)})
        return out


@dataclass(frozen=True)
class FinalRecord:
    """The chosen result: the candidate it started from, its fit, pose, rotation gate angle and method."""

    init: str
    fit: Fit
    pose: PoseSummary
    rotation_gate_deg: float
    method: str

    def to_json(self) -> dict[str, Any]:
        return {
            "init": self.init,
            "fit": self.fit.to_json(),
            "symmetric_fitness": self.fit.symmetric_fitness,
            "pose": self.pose.to_json(),
            "rotation_gate_deg": self.rotation_gate_deg,
            "method": self.method,
        }


@dataclass(frozen=True)
class CloudSummary:
    """The clouds registration worked on: point counts, both normalisations and robust boxes, the inlier
    threshold (m) and what the rotation gates measure against ('prior' or 'gravity-up tilt')."""

    target_points: int
    target_points_used: int
    target_points_dropped_as_stray: int
    source_samples: int
    source_normalisation: Normalisation
    target_normalisation: Normalisation
    source_robust_box: Normalisation
    target_robust_box: Normalisation
    inlier_threshold_m: float
    rotation_gate_reference: str

    def to_json(self) -> dict[str, Any]:
        return {
            "target_points": self.target_points,
            "target_points_used": self.target_points_used,
            "target_points_dropped_as_stray": self.target_points_dropped_as_stray,
            "source_samples": self.source_samples,
            "source_normalisation": self.source_normalisation.to_json(),
            "target_normalisation": self.target_normalisation.to_json(),
            "source_robust_box": self.source_robust_box.to_json(),
            "target_robust_box": self.target_robust_box.to_json(),
            "inlier_threshold_m": self.inlier_threshold_m,
            "rotation_gate_reference": self.rotation_gate_reference,
        }


@dataclass(frozen=True)
class SearchRecord:
    """The RANSAC search: its error (an Open3D failure leaves the normalisation pose), the restarts run and
    the seeds (sampling: numpy's for the source samples and target subsample; ransac: Open3D's per restart)."""

    error: str | None
    restarts_run: int
    sampling_seed: int
    ransac_seeds: list[int]


@dataclass
class RegistrationDiagnostics:
    """Every decision of one registration. Filled stage by stage; a rejected input stops after ``rejected``."""

    config: RegistrationConfig
    backend: str
    clouds: CloudSummary | None = None
    search: SearchRecord | None = None
    init: InitRecord | None = None
    refinement: RefinementRecord | None = None
    final: FinalRecord | None = None
    seconds: float | None = None
    rejected: str | None = None
    """Why the input or the result was rejected (the Missing's reason), or None."""

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"config": self.config.model_dump(mode="json"), "backend": self.backend}
        if self.clouds is not None:
            out.update(self.clouds.to_json())
        if self.search is not None:
            out["ransac_error"] = self.search.error
            out["ransac_restarts_run"] = self.search.restarts_run
            out["seeds"] = {"sampling": self.search.sampling_seed, "ransac": list(self.search.ransac_seeds)}
        if self.init is not None:
            out["init"] = self.init.to_json()
        if self.refinement is not None:
            out["refinement"] = self.refinement.to_json()
        if self.final is not None:
            out["final"] = self.final.to_json()
            out["rmse"] = self.final.fit.rmse
            out["inlier_ratio"] = self.final.fit.inlier_ratio
        if self.seconds is not None:
            out["seconds"] = self.seconds
        if self.rejected is not None:
            out["rejected"] = self.rejected
        return out
