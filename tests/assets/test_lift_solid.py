"""The lift solid keeps an object's parts that thin structures barely connect, and drops far strays."""

import numpy as np
import trimesh

from rescene_core.assets.lift import solid_from_points
from rescene_core.config import AssetConfig


def _lamp_points(rng: np.random.Generator) -> np.ndarray:
    """A lamp as point samples (m): a base disc, a shade, and a stem with a 4 cm gap (depth dropouts)."""
    base = np.column_stack([rng.uniform(-0.08, 0.08, (400, 2)), rng.uniform(0.0, 0.03, 400)])
    shade = np.column_stack([rng.uniform(-0.12, 0.12, (1500, 2)), rng.uniform(0.30, 0.50, 1500)])
    z = rng.uniform(0.03, 0.30, 600)
    z = z[(z < 0.14) | (z > 0.18)]
    stem = np.column_stack([rng.uniform(-0.005, 0.005, (len(z), 2)), z])
    return np.concatenate([base, stem, shade])


def test_parts_a_few_cells_apart_stay_one_object():
    points = _lamp_points(np.random.default_rng(0))
    cfg = AssetConfig()
    strict = trimesh.Trimesh(*solid_from_points(points, cfg.lift.resolution, 0))
    joined = trimesh.Trimesh(*solid_from_points(points, cfg.lift.resolution, cfg.lift.join_cells))
    assert np.ptp(strict.vertices[:, 2]) < 0.4  # shade and upper stem only: the base is lost
    assert abs(np.ptp(joined.vertices[:, 2]) - 0.5) < 0.05
    assert joined.is_watertight


def test_far_stray_island_is_still_dropped():
    rng = np.random.default_rng(1)
    points = _lamp_points(rng)
    stray = rng.uniform(-0.01, 0.01, (30, 3)) + np.array([0.6, 0.0, 0.25])  # bleed 0.5 m beside the lamp
    cfg = AssetConfig()
    mesh = trimesh.Trimesh(
        *solid_from_points(np.concatenate([points, stray]), cfg.lift.resolution, cfg.lift.join_cells)
    )
    assert mesh.vertices[:, 0].max() < 0.2
