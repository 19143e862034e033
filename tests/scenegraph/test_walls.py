"""Wall relations: which wall a wall-mounted thing hangs on, and things hung just above furniture.

Two fusion defects these guard against: at a room corner the count-based back surface of a flat picture
is as close to the perpendicular wall (its side edge touches it) as to its own wall, and a picture hung a
couple of centimetres above a sofa back or a wall shelf was answered `rests-on` that furniture.
"""

import numpy as np
import pytest

from rescene_core.capture import open_capture, write_capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import InstanceId, Relation, RoomShell, Root
from rescene_core.scenegraph import fuse_with_report, make_predictor, predict_frames
from rescene_core.scenegraph.geom import heights, wall_back, wall_fit
from rescene_core.scenegraph.priors import (
    InstanceGeometry,
    footprint_axes,
    normal_agreement,
    shell_prior,
    wall_alignment,
)
from tests.scenegraph.room import BOXES, SIZE, room_arrays, room_shell

CFG = SceneGraphConfig()
WALL_X, WALL_Y = 1, 3  # room_shell(): wall 1 is x = SIZE (normal -x), wall 3 is y = SIZE (normal -y)


def geometry(points: np.ndarray, shell: RoomShell) -> InstanceGeometry:
    """The priors' view of a hand-made point set (no normals needed for the wall prior)."""
    h = heights(shell, points)
    yaw, elongation = footprint_axes(points[:, :2])
    return InstanceGeometry(
        InstanceId(50), points, h, np.zeros(len(points), bool), float(h.min()), float(h.max()), 1.0, yaw, elongation
    )


def box_surface(lo, hi, n: int, rng) -> np.ndarray:
    """n points uniformly in the axis-aligned box [lo, hi] (m)."""
    return rng.uniform(lo, hi, size=(n, 3))


def test_picture_in_a_corner_hangs_on_its_own_wall():
    """A flat picture on the y = SIZE wall whose side edge touches the x = SIZE wall: the side is nearer
    to x = SIZE than its back to y = SIZE, but it lies along y = SIZE."""
    shell = room_shell()
    rng = np.random.default_rng(0)
    pts = box_surface((SIZE - 1.6, SIZE - 0.06, 1.2), (SIZE, SIZE - 0.015, 1.8), 3000, rng)
    # the defect: the count-based back surface is closer to the corner wall than to the picture's own wall
    assert wall_fit(pts, shell.walls[WALL_X])[0] < wall_fit(pts, shell.walls[WALL_Y])[0]
    g = geometry(pts, shell)
    assert g.elongation > 0.9
    score, wall_id = wall_alignment(g, shell, CFG)
    assert wall_id == WALL_Y and score > 0.8


def test_wall_shelf_with_stray_points_keeps_its_wall():
    """A 0.21 m deep, 0.75 m long shelf on the x = SIZE wall, near the y = SIZE corner, whose cloud carries
    1.5% stray points (mask bleed): some behind its wall, some right at the other wall."""
    shell = room_shell()
    rng = np.random.default_rng(1)
    body = box_surface((SIZE - 0.21, SIZE - 1.05, 1.4), (SIZE - 0.005, SIZE - 0.30, 1.56), 2000, rng)
    behind = box_surface((SIZE + 0.2, SIZE - 0.9, 1.4), (SIZE + 0.5, SIZE - 0.5, 1.5), 15, rng)
    at_corner = box_surface((SIZE - 0.2, SIZE - 0.01, 1.4), (SIZE - 0.1, SIZE + 0.02, 1.5), 15, rng)
    g = geometry(np.concatenate([body, behind, at_corner]), shell)
    score, wall_id = wall_alignment(g, shell, CFG)
    assert wall_id == WALL_X and score > 0.5


def test_normal_agreement_modulo_90_for_square_and_180_for_elongated_footprints():
    shell = room_shell()
    rng = np.random.default_rng(2)
    square = geometry(box_surface((1.0, 1.0, 1.0), (1.4, 1.4, 1.3), 2000, rng), shell)
    long_x = geometry(box_surface((1.0, 1.0, 1.0), (2.2, 1.05, 1.3), 2000, rng), shell)
    nx, ny = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    # a square footprint may face any side to a wall
    assert normal_agreement(square, nx) == pytest.approx(1.0, abs=0.05)
    assert normal_agreement(square, ny) == pytest.approx(1.0, abs=0.05)
    # an elongated one along x hangs on a wall whose normal is y, not on one whose normal is x
    assert normal_agreement(long_x, ny) == pytest.approx(1.0, abs=0.02)
    assert normal_agreement(long_x, nx) < 0.1


# The test room with a low sofa-like block against the y = SIZE wall and the picture hung 2 cm above its
# top, flush with that wall (the picture's bottom edge is within the backends' support tolerance of the
# block's upward face), plus a wall shelf on the x = 0 wall with a second picture 3 cm above it.
ABOVE = dict(BOXES)
ABOVE[8] = ("picture", False, (0.7, 0.03, 0.45), (2.0, SIZE - 0.015, 0.82 + 0.225))
ABOVE[11] = ("sofa", False, (1.6, 0.8, 0.8), (2.0, SIZE - 0.4, 0.4))
ABOVE[12] = ("wall shelf", False, (0.21, 0.75, 0.16), (0.105, 2.6, 1.48))
ABOVE[13] = ("picture", False, (0.025, 0.7, 0.38), (0.0125, 2.6, 1.56 + 0.03 + 0.19))
ABOVE_GT = {
    8: (Relation.MOUNTS_ON, Root.WALL, 3),
    11: (Relation.RESTS_ON, Root.FLOOR, None),
    12: (Relation.MOUNTS_ON, Root.WALL, 0),
    13: (Relation.MOUNTS_ON, Root.WALL, 0),
}


@pytest.fixture(scope="module")
def above_capture(tmp_path_factory):
    path = tmp_path_factory.mktemp("above") / "above.zarr"
    write_capture(path, room_arrays(boxes=ABOVE))
    return open_capture(path)


@pytest.fixture(scope="module")
def above_predictions(above_capture):
    frames = list(range(above_capture.num_frames))
    return predict_frames(above_capture, frames, room_shell(), CFG, make_predictor(CFG))


def test_geometric_backend_hangs_pictures_just_above_furniture_on_the_wall(above_predictions):
    shown = {8: 0, 13: 0}
    for p in above_predictions:
        for child in shown:
            if child in p.relations:
                shown[child] += 1
                assert p.relations[child] == (Relation.MOUNTS_ON, Root.WALL), (p.frame, child)
        # what stands on furniture keeps its support: the lamp on the table
        if 7 in p.relations and 6 in p.relations:
            assert p.relations[7] == (Relation.RESTS_ON, 6)
    assert min(shown.values()) >= 2


def test_fusion_hangs_them_on_the_right_wall(above_capture, above_predictions):
    graph, report = fuse_with_report(above_predictions, above_capture, room_shell(), CFG)
    edges = graph.parent_of()
    for child, (rel, parent, wall_id) in ABOVE_GT.items():
        e = edges[InstanceId(child)]
        assert (e.relation, e.parent) == (rel, parent), (child, report.candidates[child])
        assert e.wall_id == wall_id
    assert edges[InstanceId(7)].parent == InstanceId(6)


def noisy_picture(rng, sigma: float, n: int = 3000) -> np.ndarray:
    """A 0.8 x 0.5 m picture 1.5 cm in front of the y = SIZE wall, its depth spread by sigma (m) along the
    wall normal, as the cluttered captures' depth spreads a mirror's points (10-90% range 11-14 cm)."""
    pts = box_surface((1.0, SIZE - 0.015, 1.2), (1.8, SIZE - 0.015, 1.7), n, rng)
    pts[:, 1] += rng.normal(0.0, sigma, n)
    return pts


def test_depth_noise_around_a_flush_picture_is_not_a_gap_to_its_wall():
    """A flush picture whose noisy points lie on both sides of its wall plane: its back reaches the wall, so
    the wall prior and the shell prior are near 1 (they counted the points behind the plane as distance:
    G 0.88 and shell 0.4 at 4 cm noise, which capped the edge's confidence and so the solver's yaw)."""
    shell = room_shell()
    wall = shell.walls[WALL_Y]
    pts = noisy_picture(np.random.default_rng(3), sigma=0.04)
    assert np.mean(wall.plane.signed_distance(pts) < 0) > 0.3  # a third of the points lie behind the plane
    assert wall_back(pts, wall) < 0.01
    g = geometry(pts, shell)
    score, wall_id = wall_alignment(g, shell, CFG)
    assert wall_id == WALL_Y and score > 0.95
    assert shell_prior(g, Root.WALL, shell, CFG) > 0.95


def test_back_distance_stays_for_things_in_front_of_or_behind_a_wall():
    """One-sided only where the points straddle the plane: a monitor's back 20 cm in front of the wall and a
    thing whose bulk lies 30 cm behind it (the other side of the wall) are that far from it."""
    shell = room_shell()
    wall = shell.walls[WALL_Y]
    rng = np.random.default_rng(4)
    monitor = box_surface((1.0, SIZE - 0.45, 0.9), (1.6, SIZE - 0.2, 1.3), 2000, rng)
    assert wall_back(monitor, wall) == pytest.approx(0.225, abs=0.01)
    behind = box_surface((1.0, SIZE + 0.25, 0.9), (1.6, SIZE + 0.35, 1.3), 2000, rng)
    assert wall_back(behind, wall) == pytest.approx(0.30, abs=0.01)
    score, _ = wall_alignment(geometry(behind, shell), shell, CFG)
    assert score < 0.01
