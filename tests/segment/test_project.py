"""Filling the pixels a ray cast leaves unlabelled from the labelled surface their measured point lies on."""

from __future__ import annotations

import numpy as np

from rescene_core.segment.project import fill_from_surface


def test_a_pixel_the_cast_left_empty_takes_the_label_of_the_surface_under_its_point_within_the_radius():
    # one camera at the origin looking down +z (OpenCV axes), 40 x 30 pixels, focal length 20 px; a wall at
    # z = 2 m seen by every pixel; the mesh's vertices on it every 2 cm, the left half labelled 5 (an
    # object), the right half 0 (no instance). The cast labelled nothing (a hole in the mesh, say).
    W, H = 40, 30
    K = np.array([[20.0, 0.0, 20.0], [0.0, 20.0, 15.0], [0.0, 0.0, 1.0]])
    world_from_cam = np.eye(4)
    depth = np.full((1, H, W), 2.0, np.float32)
    xs, ys = np.meshgrid(np.arange(-2.0, 2.0, 0.02), np.arange(-1.6, 1.6, 0.02))
    vertices = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 2.0)], axis=1)
    labels = np.where(vertices[:, 0] < 0.0, 5, 0)
    # a band of pixels measures a surface 10 cm in front of the mesh: nothing there is filled
    depth[0, 20:, :] = 1.9
    masks = np.zeros((1, H, W), np.int32)
    masks[0, 0, 0] = 7  # a pixel the cast labelled keeps its label

    filled = fill_from_surface(masks, depth, K[None], world_from_cam[None], vertices, labels, radius=0.03)

    x = (np.arange(W) + 0.5 - 20.0) / 20.0 * 2.0  # the measured point's x of each column on the wall
    assert masks[0, 0, 0] == 7
    assert (masks[0, 1:20][:, x < -0.02] == 5).all() and (masks[0, 1:20][:, x > 0.02] == 0).all()
    assert (masks[0, 20:] == 0).all()
    assert filled == int((masks[0] == 5).sum())
