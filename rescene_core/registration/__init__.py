"""Bounded Sim(3) registration of generated assets to instance point clouds (paper Sec. 3.3)."""

from rescene_core.geometry.open3d_rng import OPEN3D_RNG_LOCK, seeded_open3d_rng
from rescene_core.registration.bounded_icp import IcpResult, bounded_sim3_icp, clamp_rotation, umeyama
from rescene_core.registration.fit import Fit, FitEvaluator, add_s
from rescene_core.registration.pipeline import degeneracy, register, register_detailed, rotation_gate_angle

__all__ = [
    "Fit",
    "FitEvaluator",
    "IcpResult",
    "OPEN3D_RNG_LOCK",
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
