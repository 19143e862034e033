"""Bounded Sim(3) registration of generated assets to instance point clouds (paper Sec. 3.3).

``pipeline`` runs the steps: ``gates`` (input, initialisation and result gates), ``candidates`` (FPFH +
RANSAC initialisations), ``refinement`` (bounded ICP and its fallback); ``diagnostics`` is the typed
record of every decision, written to pose.json.
"""

from rescene_core.geometry.open3d_rng import OPEN3D_RNG_LOCK, seeded_open3d_rng
from rescene_core.registration.bounded_icp import IcpResult, bounded_sim3_icp, clamp_rotation, umeyama
from rescene_core.registration.diagnostics import RegistrationDiagnostics
from rescene_core.registration.fit import Fit, FitEvaluator, add_s
from rescene_core.registration.gates import degeneracy, rotation_gate_angle
from rescene_core.registration.pipeline import register, register_detailed

__all__ = [
    "Fit",
    "FitEvaluator",
    "IcpResult",
    "OPEN3D_RNG_LOCK",
    "RegistrationDiagnostics",
    "add_s",
    "bounded_sim3_icp",
    "clamp_rotation",
    "degeneracy",
    "register",
    "register_detailed",
    "rotation_gate_angle",
    "seeded_open3d_rng",
    "umeyama",
]
