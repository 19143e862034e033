"""Stray points in instance clouds: on cluttered scenes an instance's cloud carries a few percent of
points from mask edges and mixed depth, scattered across the room. Left in, they set the lower contact
surface (a book on a table "touches" the floor) and the footprint rectangle (a mirror's long side no
longer lies along its wall), so correct edges lost their geometric support or the wrong one won."""

import numpy as np
import open3d as o3d
import pytest

from rescene_core.config import FusionConfig, SceneGraphConfig
from rescene_core.records import InstanceId
from rescene_core.scenegraph.priors import (
    drop_strays,
    floor_contact,
    instance_geometry,
    object_support,
    wall_alignment,
)
from tests.scenegraph.room import SIZE, room_shell

WALL_Y = 3  # room_shell(): wall 3 is y = SIZE (normal -y)


class CloudCapture:
    """The one thing the priors read from a capture: ``point_cloud(instance)``."""

    def __init__(self, clouds: dict[int, np.ndarray]):
        self.clouds = clouds

    def point_cloud(self, instance: int) -> o3d.geometry.PointCloud:
        return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.clouds[int(instance)]))


def box(lo, hi, n: int, rng) -> np.ndarray:
    return rng.uniform(lo, hi, size=(n, 3))


def strays(n: int, rng) -> np.ndarray:
    """n points scattered over the whole room, floor to ceiling."""
    return rng.uniform((0.0, 0.0, 0.0), (SIZE, SIZE, 2.4), size=(n, 3))


def test_drop_strays_keeps_the_body_and_drops_scattered_points():
    rng = np.random.default_rng(0)
    body = box((1.0, 1.0, 0.75), (1.3, 1.2, 0.9), 3000, rng)
    pts = np.concatenate([body, strays(60, rng)])
    kept = drop_strays(pts, SceneGraphConfig())
    assert len(body) - 10 <= len(kept) < len(pts) - 50
    assert kept[:, 2].min() > 0.74
    assert len(drop_strays(pts, SceneGraphConfig(fusion=FusionConfig(outlier_min_points=0)))) == len(pts)
    # too few points, or a cloud the filter would mostly empty, comes back unchanged
    sparse = strays(40, rng)
    assert len(drop_strays(sparse, SceneGraphConfig())) == len(sparse)


def test_mirror_with_strays_keeps_its_wall_alignment():
    """A 0.6 m wide mirror on the y = SIZE wall; 2% strays at its heights, scattered along a diagonal
    through the room (mask-edge pixels seen from one side), turn its footprint rectangle diagonal."""
    shell = room_shell()
    rng = np.random.default_rng(1)
    mirror = box((1.5, SIZE - 0.03, 1.2), (2.1, SIZE - 0.005, 1.9), 3000, rng)
    t = rng.uniform(0.0, 1.0, 60)
    streak = np.column_stack([1.8 + 2.0 * t, SIZE - 2.0 * t, rng.uniform(1.2, 1.9, 60)])
    cap = CloudCapture({5: np.concatenate([mirror, streak])})
    raw = instance_geometry(cap, 5, shell, SceneGraphConfig(fusion=FusionConfig(outlier_min_points=0)))
    clean = instance_geometry(cap, 5, shell, SceneGraphConfig())
    raw_score, _ = wall_alignment(raw, shell, SceneGraphConfig())
    score, wall_id = wall_alignment(clean, shell, SceneGraphConfig())
    assert raw_score < 0.5  # the defect
    assert wall_id == WALL_Y and score > 0.8


def test_book_on_a_table_with_strays_is_supported_by_the_table_not_the_floor():
    shell = room_shell()
    rng = np.random.default_rng(2)
    top = box((1.0, 1.0, 0.74), (2.0, 1.6, 0.75), 4000, rng)
    legs = np.concatenate(
        [box((x, y, 0.0), (x + 0.05, y + 0.05, 0.74), 300, rng) for x in (1.0, 1.95) for y in (1.0, 1.55)]
    )
    book = box((1.4, 1.2, 0.75), (1.65, 1.4, 0.85), 3000, rng)
    cap = CloudCapture({1: np.concatenate([top, legs]), 2: np.concatenate([book, strays(80, rng)])})
    cfg = SceneGraphConfig()
    table = instance_geometry(cap, 1, shell, cfg)
    raw = instance_geometry(cap, 2, shell, SceneGraphConfig(fusion=FusionConfig(outlier_min_points=0)))
    clean = instance_geometry(cap, 2, shell, cfg)
    assert raw.bottom < 0.3 and floor_contact(raw, cfg) > 0.0  # the defect: strays below the book
    assert clean.bottom == pytest.approx(0.75, abs=0.01)
    assert table.bottom == pytest.approx(0.0, abs=0.01)  # thin legs are not strays
    assert floor_contact(clean, cfg) < 1e-6
    assert object_support(clean, table, cfg) > 0.8
    assert clean.instance == InstanceId(2)
