"""When the geometric backend takes an object's base to be hidden rather than absent
(``scenegraph.geometric.bottom_occluded``)."""

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
