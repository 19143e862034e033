import numpy as np
import pytest
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation

from rescene_core.geometry import sim3


def random_sim3(rng: np.random.Generator, angle: float | None = None, log_scale: float | None = None) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    theta = rng.uniform(0, np.pi) if angle is None else angle
    sigma = rng.uniform(-2.5, 2.5) if log_scale is None else log_scale
    return sim3.sim3_from_parts(
        np.exp(sigma), Rotation.from_rotvec(theta * axis).as_matrix(), rng.normal(scale=3, size=3)
    )


def generator(xi: np.ndarray) -> np.ndarray:
    g = np.zeros((4, 4))
    g[:3, :3] = xi[6] * np.eye(3) + sim3.hat(xi[3:6])
    g[:3, 3] = xi[:3]
    return g


@pytest.mark.parametrize("seed", range(20))
def test_exp_matches_scipy_expm(seed):
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    xi = np.concatenate([rng.normal(size=3), axis / np.linalg.norm(axis) * rng.uniform(0, np.pi), [rng.uniform(-3, 3)]])
    np.testing.assert_allclose(sim3.exp(xi), expm(generator(xi)), atol=1e-9, rtol=1e-9)


@pytest.mark.parametrize("seed", range(20))
def test_log_matches_scipy_logm(seed):
    m = random_sim3(np.random.default_rng(seed), angle=np.random.default_rng(seed).uniform(0, 3.0))
    np.testing.assert_allclose(generator(sim3.log(m)), logm(m).real, atol=1e-8)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-6, 0.5, np.pi - 1e-3, np.pi - 1e-7, np.pi])
@pytest.mark.parametrize("log_scale", [-4.0, -1e-9, 0.0, 1e-9, 2.0, 4.6])
def test_exp_log_round_trip_including_near_pi_and_far_scales(angle, log_scale):
    rng = np.random.default_rng(1)
    m = random_sim3(rng, angle=angle, log_scale=log_scale)
    back = sim3.exp(sim3.log(m))
    np.testing.assert_allclose(back, m, atol=1e-9 * max(1.0, np.abs(m).max()))


def test_rotation_part_agrees_with_scipy_rotation():
    rng = np.random.default_rng(3)
    for _ in range(50):
        m = random_sim3(rng)
        s, rot, _ = sim3.parts_from_sim3(m)
        xi = sim3.log(m)
        np.testing.assert_allclose(Rotation.from_rotvec(xi[3:6]).as_matrix(), rot, atol=1e-10)
        assert abs(np.exp(xi[6]) - s) < 1e-9 * s


def test_compose_inverse_apply():
    rng = np.random.default_rng(4)
    a, b = random_sim3(rng), random_sim3(rng)
    pts = rng.normal(size=(10, 3))
    np.testing.assert_allclose(sim3.apply(sim3.compose(a, b), pts), sim3.apply(a, sim3.apply(b, pts)), atol=1e-9)
    np.testing.assert_allclose(sim3.compose(a, sim3.inverse(a)), np.eye(4), atol=1e-9)
    np.testing.assert_allclose(sim3.inverse(a), np.linalg.inv(a), atol=1e-9)


def test_confidence_scaling_endpoints_and_geodesic():
    rng = np.random.default_rng(5)
    m = random_sim3(rng, angle=2.0)
    np.testing.assert_allclose(sim3.scale_by_confidence(m, 0.0), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(sim3.scale_by_confidence(m, 1.0), m, atol=1e-9)
    half = sim3.scale_by_confidence(m, 0.5)
    np.testing.assert_allclose(half @ half, m, atol=1e-9)
    s_half, rot_half, _ = sim3.parts_from_sim3(half)
    s, rot, _ = sim3.parts_from_sim3(m)
    assert abs(s_half - np.sqrt(s)) < 1e-12
    assert abs(sim3.rotation_angle(rot_half) - sim3.rotation_angle(rot) / 2) < 1e-9


def test_bad_input_rejected():
    with pytest.raises(sim3.Sim3Error):
        sim3.sim3_from_parts(0.0, np.eye(3), np.zeros(3))
    with pytest.raises(sim3.Sim3Error):
        sim3.parts_from_sim3(np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(sim3.Sim3Error):
        sim3.exp(np.zeros(6))
    assert sim3.check_sim3(np.eye(4)) == []
    assert sim3.check_sim3(np.full((4, 4), np.nan))
    shear = np.eye(4)
    shear[0, 1] = 0.3
    assert any("scaled rotation" in p for p in sim3.check_sim3(shear))
