"""The lift asset's depth: footprint-aligned mirror axes and a solid that spans exactly its points."""

import numpy as np
import pytest
import trimesh

from rescene_core.assets import finish_asset
from rescene_core.assets.lift import LiftBackend, footprint_yaw, solid_from_points
from rescene_core.config import AssetConfig
from rescene_core.records import InstanceId
from tests.assets.test_assets import _noisy, _upright_extents, look_at_camera, render_view

CONFIG = AssetConfig()


def _desk(yaw_deg: float) -> trimesh.Trimesh:
    """A 1.5 x 0.7 x 0.75 m desk (4 cm top on four 5 cm legs), turned by ``yaw_deg`` about z."""
    parts = [trimesh.creation.box((1.5, 0.7, 0.04), trimesh.transformations.translation_matrix((0, 0, 0.73)))]
    for sx in (-1, 1):
        for sy in (-1, 1):
            leg = trimesh.transformations.translation_matrix((sx * 0.7, sy * 0.3, 0.355))
            parts.append(trimesh.creation.box((0.05, 0.05, 0.71), leg))
    desk = trimesh.util.concatenate(parts)
    desk.apply_transform(trimesh.transformations.rotation_matrix(np.radians(yaw_deg), [0, 0, 1]))
    return desk


def test_footprint_yaw_finds_a_rectangles_sides():
    rng = np.random.default_rng(0)
    # an L of two faces of a 1.2 x 0.5 m box, turned by 20 degrees, with 1 cm noise
    front = np.column_stack([rng.uniform(-0.6, 0.6, 800), np.full(800, 0.25), rng.uniform(0, 0.7, 800)])
    side = np.column_stack([np.full(400, 0.6), rng.uniform(-0.25, 0.25, 400), rng.uniform(0, 0.7, 400)])
    points = np.concatenate([front, side]) + rng.normal(0, 0.01, (1200, 3))
    c, s = np.cos(np.radians(20)), np.sin(np.radians(20))
    points = points @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])
    yaw, area = footprint_yaw(points, 0.0)
    assert abs(np.degrees(yaw) - 20.0) < 3.0
    assert area < 1.15 * 1.2 * 0.5


@pytest.mark.parametrize("sigma", [0.0, 0.01])
def test_desk_seen_from_above_off_axis_keeps_its_depth(sigma):
    # the top seen from above 17 degrees off the desk's front: the visible surface is mostly the top,
    # whose normals are vertical, so the faces barely vote; the footprint gives the desk's axes
    desk = _desk(17.0)
    eye = np.array([0.0, 2.6, 2.0])
    view = _noisy(render_view(desk, look_at_camera(eye, np.array([0.0, 0.0, 0.5]), width=200, height=150)), sigma)
    asset = finish_asset(InstanceId(5), "lift", LiftBackend(CONFIG).generate(view))
    width, depth, _ = _upright_extents(asset)
    assert abs(width - 1.5) < 0.12
    assert depth < 0.7 * 1.2  # the view direction as mirror normal gave about 1.0 m
    facing = np.asarray(asset.metadata["shape"]["facing"])
    yaw = np.degrees(np.arctan2(facing[1], facing[0]))
    assert abs((yaw - 17.0 + 45.0) % 90.0 - 45.0) < 4.0


def test_solid_spans_its_points_without_a_cell_of_growth():
    rng = np.random.default_rng(2)
    # a 1.7 m tall, 0.9 wide, 0.33 deep block of points: one grid cell (1.7 / 40 = 4 cm) is 13 % of its depth
    points = rng.uniform([-0.45, -0.165, 0.0], [0.45, 0.165, 1.7], (20000, 3))
    mesh = trimesh.Trimesh(*solid_from_points(points, CONFIG.lift.resolution, CONFIG.lift.join_cells))
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), np.ptp(points, axis=0), rtol=1e-6)
    assert mesh.is_watertight
