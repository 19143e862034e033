"""Two of the geometric backend's per-frame rules: when it takes an object's base to be hidden rather than
absent (``scenegraph.geometric.bottom_occluded``), and that a thing flat on a wall carries nothing."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rescene_core.scenegraph.geometric import bottom_occluded


def _view(left: int, right: int, below: int = 0, below_depth: float = 3.0) -> SimpleNamespace:
    """A 60 x 80 frame: a lamp's head (instance 7) at 2 m in rows 10-19 and columns [left, right); under it
    the wall (background 0, 3 m), or instance ``below`` at ``below_depth`` m."""
    mask = np.zeros((60, 80), np.int32)
    depth = np.full((60, 80), 3.0)
    mask[10:20, left:right] = 7
    depth[10:20, left:right] = 2.0
    if below:
        mask[20:40, left:right] = below
        depth[20:40, left:right] = below_depth
    return SimpleNamespace(mask=mask, depth=depth)


def test_an_object_running_off_the_side_of_the_frame_may_have_its_base_outside_it():
    assert bottom_occluded(_view(0, 12), 7)  # the head in the picture's corner, its stem outside the frame
    assert bottom_occluded(_view(70, 80), 7)
    assert not bottom_occluded(_view(30, 42), 7)  # wholly in the frame, the wall seen under it: no base


def test_a_nearer_object_below_hides_the_base_and_a_farther_one_does_not():
    assert bottom_occluded(_view(30, 42, below=3, below_depth=1.5), 7)
    assert not bottom_occluded(_view(30, 42, below=3, below_depth=2.8), 7)


def test_a_shelf_just_above_a_mirror_hangs_on_the_wall_not_on_the_mirror():
    # a mirror flat on the wall y = 0 (x 1-2, z 0.6-1.5, 2 cm thick, its top edge facing up) and a wall
    # shelf 22 cm deep 1 cm above it: the mirror's top edge is an upward surface at the shelf's bottom
    from rescene_core.config import SceneGraphConfig
    from rescene_core.records import Plane, RoomShell, WallPlane
    from rescene_core.scenegraph.geom import heights, lower_surface, upward_mask
    from rescene_core.scenegraph.geometric import GeometricPredictor

    rng = np.random.default_rng(0)
    shell = RoomShell(
        Plane((0.0, 0.0, 1.0), 0.0),
        (WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (4.0, 0.0))),),
        ((0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)),
        2.6,
    )
    front = np.c_[rng.uniform(1.0, 2.0, 3000), np.full(3000, 0.02), rng.uniform(0.6, 1.5, 3000)]
    edge = np.c_[rng.uniform(1.0, 2.0, 400), rng.uniform(0.0, 0.02, 400), np.full(400, 1.5)]
    mirror = np.vstack([front, edge])
    shelf_front = np.c_[rng.uniform(1.1, 1.9, 1500), np.full(1500, 0.22), rng.uniform(1.51, 1.68, 1500)]
    shelf_top = np.c_[rng.uniform(1.1, 1.9, 1500), rng.uniform(0.0, 0.22, 1500), np.full(1500, 1.68)]
    shelf_bottom = np.c_[rng.uniform(1.1, 1.9, 800), rng.uniform(0.0, 0.22, 800), np.full(800, 1.51)]
    pts = {1: mirror, 2: np.vstack([shelf_front, shelf_top, shelf_bottom])}
    cfg = SceneGraphConfig().geometric
    h = {d: heights(shell, p) for d, p in pts.items()}
    bottom = {d: lower_surface(h[d]) for d in pts}
    up = {d: upward_mask(p, shell, cfg.normal_neighbours, cfg.upward_normal_deg) for d, p in pts.items()}
    decide = GeometricPredictor._decide
    assert decide(1, pts, h, up, bottom, {}, shell, cfg) == ("mounts-on", "wall")
    assert decide(2, pts, h, up, bottom, {}, shell, cfg) == ("mounts-on", "wall")
