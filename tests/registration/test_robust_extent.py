"""Robust extents: stray points fused into a target do not inflate the registered scale."""

import numpy as np

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.records import InstanceId, InstancePoints, Pose
from rescene_core.registration import candidates as candidates_module
from rescene_core.registration import register_detailed
from rescene_core.registration.init import Normalisation
from tests.registration.fixtures import chair_mesh, random_world_from_object, scan, unit_box_asset


def _strays(rng, anchor, direction, count, length):
    """``count`` points on a connected strip from ``anchor`` along ``direction`` (m), 2 cm thick."""
    t = rng.uniform(0.0, length, size=count)[:, None]
    return anchor + t * direction + rng.normal(scale=0.01, size=(count, 3))


def test_percentile_box_ignores_a_few_stray_points():
    rng = np.random.default_rng(0)
    clean = rng.uniform(-0.5, 0.5, size=(5000, 3))
    strays = _strays(rng, np.array([0.5, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), 60, 1.0)  # 1.2 %
    cloud = np.concatenate([clean, strays])
    box, robust, reference = Normalisation.of(cloud), Normalisation.of(cloud, 2.0), Normalisation.of(clean, 2.0)
    assert box.extent > 1.3 * reference.extent  # the bounding box follows the strays
    assert abs(robust.extent / reference.extent - 1.0) < 0.02
    assert np.allclose(robust.centre, reference.centre, atol=0.02)
    zero = Normalisation.of(cloud, 0.0)
    assert zero.extent == box.extent and np.array_equal(zero.centre, box.centre)


def _polluted_case(seed: int = 3):
    """A chair scan with neighbour pollution on two sides (1.5 % of the points each, connected to the chair)."""
    rng = np.random.default_rng(seed)
    mesh = chair_mesh()
    hidden = random_world_from_object(rng, 10)
    hidden[:3, :3] *= 1.3
    asset, asset_from_object = unit_box_asset(mesh, hidden)
    world_from_object = random_world_from_object(rng, 0)
    target = scan(mesh, world_from_object, rng, partial=False, noise=0.004)
    pts = np.asarray(target.points, np.float64)
    count = int(0.015 * len(pts))
    rot = world_from_object[:3, :3]
    centre = sim3.apply(world_from_object, np.array([[0.0, 0.0, 0.45]]))[0]
    side = _strays(rng, centre + rot @ np.array([0.25, 0.0, 0.0]), rot @ np.array([1.0, 0.0, 0.0]), count, 0.7)
    back = _strays(rng, centre + rot @ np.array([0.0, -0.25, 0.0]), rot @ np.array([0.0, -1.0, 0.0]), count, 0.7)
    polluted = np.concatenate([pts, side, back]).astype(np.float32)
    target = InstancePoints(InstanceId(7), polluted, np.zeros((len(polluted), 3), np.uint8))
    return asset, target, sim3.compose(world_from_object, sim3.inverse(asset_from_object))


def test_polluted_target_keeps_the_scale_without_a_ransac_candidate(monkeypatch):
    """With no RANSAC candidate the normalisation pose is the initialisation and the refinement may change
    its scale by 10 % at most: the bounding box's inflation survives, the robust box's does not arise."""
    asset, target, gt = _polluted_case()
    monkeypatch.setattr(candidates_module, "fpfh_ransac_candidates", lambda *a, **k: [])
    s_true = sim3.parts_from_sim3(gt)[0]
    init, final = {}, {}
    for q in (0.0, RegistrationConfig().extent_percentile):
        pose, diag = register_detailed(asset, target, RegistrationConfig(extent_percentile=q))
        assert isinstance(pose, Pose), pose
        reference = diag.init.candidates[-1]
        assert reference.source == "normalisation"
        init[q] = reference.pose.scale / s_true - 1.0
        final[q] = sim3.parts_from_sim3(pose.world_from_asset)[0] / s_true - 1.0
    robust = RegistrationConfig().extent_percentile
    assert init[0.0] > 0.15 and final[0.0] > 0.15  # the bounding box's pose stays oversized
    assert abs(init[robust]) < 0.03
    assert abs(final[robust]) < 0.5 * final[0.0]


def test_polluted_target_with_ransac_recovers_the_scale():
    asset, target, gt = _polluted_case()
    pose, _ = register_detailed(asset, target, RegistrationConfig())
    assert isinstance(pose, Pose), pose
    assert abs(sim3.parts_from_sim3(pose.world_from_asset)[0] / sim3.parts_from_sim3(gt)[0] - 1.0) < 0.02


def test_diagnostics_record_both_boxes():
    asset, target, _ = _polluted_case(seed=5)
    pose, diag = register_detailed(asset, target, RegistrationConfig())
    assert isinstance(pose, Pose)
    assert diag.clouds.target_robust_box.extent < diag.clouds.target_normalisation.extent
    assert abs(diag.clouds.inlier_threshold_m - 0.1 * diag.clouds.target_robust_box.extent) < 1e-9
