import numpy as np
import pytest

from rescene_core.geometry import sim3
from rescene_core.geometry.camera import intrinsics_from_fov, look_at, project, project_to_pixels


def test_look_at_is_an_opencv_camera_with_a_horizontal_x_axis():
    m = look_at((0.0, 0.0, 1.5), (0.0, 2.0, 1.0))
    assert np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3)) and np.isclose(np.linalg.det(m[:3, :3]), 1.0)
    assert np.isclose(m[2, 0], 0.0)  # x stays horizontal
    assert m[2, 1] < 0  # y points down
    assert np.allclose(m[:3, 2], np.array([0.0, 2.0, -0.5]) / np.linalg.norm([0.0, 2.0, -0.5]))
    assert np.allclose(m[:3, 3], [0.0, 0.0, 1.5])


def test_look_at_roll_turns_the_image_about_the_viewing_axis():
    flat, rolled = look_at((0, 0, 1), (0, 3, 1)), look_at((0, 0, 1), (0, 3, 1), roll=0.3)
    assert np.allclose(flat[:3, 2], rolled[:3, 2])
    assert np.isclose(np.arccos(flat[:3, 0] @ rolled[:3, 0]), 0.3)


def test_look_at_rejects_undefined_directions():
    with pytest.raises(ValueError, match="coincide"):
        look_at((1, 1, 1), (1, 1, 1))
    with pytest.raises(ValueError, match="straight up or down"):
        look_at((0, 0, 1), (0, 0, 3))
    assert np.allclose(look_at((0, 0, 1), (0, 0, 3), strict=False)[:3, 0], [1, 0, 0])


def test_projection_puts_the_target_at_the_principal_point():
    K = intrinsics_from_fov(64, 48, 90.0)
    assert np.isclose(K[0, 0], 32.0) and np.allclose(K[:2, 2], [32.0, 24.0])
    pose = look_at((0.0, 0.0, 1.0), (0.0, 2.0, 1.0))
    pts = np.array([[0.0, 2.0, 1.0], [0.5, 2.0, 1.0], [0.0, -2.0, 1.0]])
    u, v, z = project(pts, K, pose)
    assert np.allclose([u[0], v[0], z[0]], [32.0, 24.0, 2.0])
    assert u[1] > 32.0  # world +x is image right when looking north
    col, row, valid = project_to_pixels(pts.astype(np.float32), K, pose, 64, 48)
    assert valid.tolist() == [True, True, False] and (col[0], row[0]) == (32, 24)


def test_scale_of_reads_the_uniform_scale():
    m = sim3.sim3_from_parts(2.5, np.eye(3), [1.0, 2.0, 3.0])
    assert np.isclose(sim3.scale_of(m), 2.5) and np.isclose(sim3.scale_of(m[:3, :3]), 2.5)
    assert sim3.scale_of(np.zeros((4, 4))) == 0.0
