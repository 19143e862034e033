"""Refinement of the accepted initialisations: bounded Sim(3) ICP, the result gate, the conservative fallback.

Each accepted candidate is refined by the bounded ICP and gated against its own pre-refinement pose
(``gates.result_gate``); a rejected refinement keeps the pre-refinement pose. A numerical failure of the
solver (``FloatingPointError``, ``LinAlgError``: a collapsed correspondence set, a non-finite or invalid
pose) falls back to Open3D point-to-point rigid ICP at the initial scale, which passes the same gate;
anything else is a defect and raises. With several candidates each first gets a short probe refinement
(``probe_iterations``); only the best probe by symmetric fitness is refined with the full budget, from
its own initialisation (the full run continues the probe's ICP where it stopped, the same computation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.registration.bounded_icp import IcpResult, bounded_sim3_icp
from rescene_core.registration.candidates import Candidate
from rescene_core.registration.diagnostics import PoseSummary, RefinedPose, RefinementRecord, SolverRun
from rescene_core.registration.fit import Fit, FitEvaluator
from rescene_core.registration.gates import result_gate

SOLVER_FAILURES = (FloatingPointError, np.linalg.LinAlgError)
"""The failures a numerical solver is expected to have on degenerate correspondences; they fall back."""


@dataclass(frozen=True)
class Refinement:
    """The outcome of refining one initialisation: pose (the initialisation when rejected), fit, method
    ('bounded_sim3_icp', 'fallback_nn_icp' or 'init_only'), diagnostics and the bounded ICP run (None
    when it failed) that a longer run can resume."""

    world_from_asset: sim3.Matrix4
    fit: Fit
    method: str
    record: RefinementRecord
    run: IcpResult | None

    @property
    def key(self) -> tuple[float, float]:
        """Ranking: symmetric fitness, then lower RMSE."""
        return (self.fit.symmetric_fitness, -self.fit.rmse)


def fallback_icp(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    init: sim3.Matrix4,
    extent: float,
    config: RegistrationConfig,
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
    refined = sim3.compose(np.asarray(result.transformation, dtype=np.float64), init)
    problems = sim3.check_sim3(refined, atol=1e-6)
    if problems:
        raise FloatingPointError(f"invalid fallback ICP output: {problems}")
    return refined


def refine(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    init: Candidate,
    evaluator: FitEvaluator,
    extent: float,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
    resume: IcpResult | None = None,
) -> Refinement:
    """Bounded ICP from ``init``, gated; a numerical solver failure falls back to the conservative rigid ICP.

    ``resume``: a shorter bounded ICP run from the same initialisation to continue (see ``bounded_sim3_icp``).
    """
    method = "bounded_sim3_icp"
    refined: sim3.Matrix4 | None = None
    solver: SolverRun | None = None
    error: str | None = None
    fallback_error: str | None = None
    result: IcpResult | None = None
    try:
        result = bounded_sim3_icp(
            source, target, init.world_from_asset, extent, config, tree=evaluator.source_tree, resume=resume
        )
        problems = sim3.check_sim3(result.world_from_asset, atol=1e-6)
        if problems:
            raise FloatingPointError(f"invalid ICP output: {problems}")
        refined = result.world_from_asset
        solver = SolverRun(
            result.iterations,
            result.stop_reason,
            result.step_clamps,
            result.total_clamps,
            result.scale_clips,
            result.history,
        )
    except SOLVER_FAILURES as err:
        result = None
        error = f"{type(err).__name__}: {err}"
        method = "fallback_nn_icp"
        try:
            refined = fallback_icp(source, target, init.world_from_asset, extent, config)
        except SOLVER_FAILURES as err2:
            fallback_error = f"{type(err2).__name__}: {err2}"
            refined = None
    if refined is None:
        record = RefinementRecord(solver, error, fallback_error, None, ("no refinement produced",))
        return Refinement(init.world_from_asset, init.fit, "init_only", record, None)
    refined_fit = evaluator(refined)
    reasons = result_gate(refined, init.world_from_asset, refined_fit, init.fit, prior, config)
    s0, rot0, _ = sim3.parts_from_sim3(init.world_from_asset)
    s_r, rot_r, _ = sim3.parts_from_sim3(refined)
    outcome = RefinedPose(
        method,
        init.fit,
        refined_fit,
        PoseSummary.of(refined),
        float(s_r / s0),
        float(np.rad2deg(sim3.rotation_angle(rot_r @ rot0.T))),
    )
    record = RefinementRecord(solver, error, fallback_error, outcome, tuple(reasons))
    if reasons:
        return Refinement(init.world_from_asset, init.fit, "init_only", record, result)
    return Refinement(refined, refined_fit, method, record, result)


def refine_best(
    source: NDArray[np.float64],
    target: NDArray[np.float64],
    accepted: list[Candidate],
    evaluator: FitEvaluator,
    extent: float,
    prior: sim3.Matrix4 | None,
    config: RegistrationConfig,
) -> tuple[Refinement, Candidate]:
    """Refine the accepted candidates (probing first when there are several) and return the best
    refinement by symmetric fitness with the candidate it started from (marked chosen)."""
    if not accepted:
        raise ValueError("refine_best needs at least one accepted initialisation")
    finalists: list[tuple[Candidate, IcpResult | None]]
    if len(accepted) > 1 and 0 < config.probe_iterations < config.max_iterations:
        probe_config = config.model_copy(update={"max_iterations": config.probe_iterations})
        probes = []
        for candidate in accepted:
            probe = refine(source, target, candidate, evaluator, extent, prior, probe_config)
            candidate.record.probe_fit = probe.fit
            probes.append(probe)
        winner = int(max(range(len(probes)), key=lambda i: probes[i].key))
        finalists = [(accepted[winner], probes[winner].run)]
    else:
        finalists = [(candidate, None) for candidate in accepted]
    best: tuple[Refinement, Candidate] | None = None
    for candidate, resume in finalists:
        refinement = refine(source, target, candidate, evaluator, extent, prior, config, resume)
        candidate.record.refined_fit = refinement.fit
        candidate.record.method = refinement.method
        if best is None or refinement.key > best[0].key:
            best = (refinement, candidate)
    if best is None:
        raise ValueError("no finalist was refined")
    best[1].record.chosen = True
    return best
