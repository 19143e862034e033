"""Superpoints on hand-made point sets: which edges are creases, Felzenszwalb-Huttenlocher keeps a crease
and a colour step apart and a flat single-colour patch whole, and the contact table between superpoints."""

from __future__ import annotations

import numpy as np

from rescene_core.segment.superpoints import edge_weights, felzenszwalb, point_graph, superpoint_graph

STEP = 0.02


def _grid(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    uu, vv = np.meshgrid(u, v, indexing="ij")
    return np.c_[uu.ravel(), vv.ravel()]


def lamp_on_table() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A table top (z = 0.7, normal +z, brown) and the -x face of a box standing on it (x = 0.5, normal -x,
    white): points [n, 3], normals, colours, and which part each point is (0 top, 1 box)."""
    top = _grid(np.arange(0.0, 0.5, STEP), np.arange(0.0, 0.6, STEP))
    top = np.c_[top, np.full(len(top), 0.7)]
    side = _grid(np.arange(0.1, 0.5, STEP), np.arange(0.7 + STEP, 0.9, STEP))
    side = np.c_[np.full(len(side), 0.5), side]
    pts = np.r_[top, side]
    nrm = np.r_[np.tile([0.0, 0.0, 1.0], (len(top), 1)), np.tile([-1.0, 0.0, 0.0], (len(side), 1))]
    col = np.r_[np.tile([0.45, 0.3, 0.2], (len(top), 1)), np.tile([0.9, 0.9, 0.85], (len(side), 1))]
    part = np.r_[np.zeros(len(top), int), np.ones(len(side), int)]
    return pts, nrm, col, part


def test_inner_corner_is_concave_and_box_edge_convex():
    pts, nrm, col, part = lamp_on_table()
    edges = point_graph(pts, STEP * 1.75)
    _, concave, _ = edge_weights(pts, nrm, col, edges, 1.0)
    across = part[edges[:, 0]] != part[edges[:, 1]]
    assert across.any() and concave[across].all()  # where the box stands on the top: a crease
    assert not concave[~across].any()  # flat parts have no creases
    # the top edge of a box: top face (+z) meets its side (+x) on the outside: convex
    box = np.array([[0.0, 0.0, 1.0], [0.01, 0.0, 1.0], [0.02, 0.0, 0.99], [0.02, 0.0, 0.98]])
    bn = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    _, conc, _ = edge_weights(box, bn, np.zeros((4, 3)), np.array([[1, 2], [0, 3]]), 1.0)
    assert not conc.any()


def test_felzenszwalb_keeps_a_crease_and_a_colour_step_apart():
    pts, nrm, col, part = lamp_on_table()
    edges = point_graph(pts, STEP * 1.75)
    w, concave, step = edge_weights(pts, nrm, col, edges, 1.0)
    label = felzenszwalb(len(pts), edges, w, k=0.5, min_size=10)
    for sp in np.unique(label):
        assert len(np.unique(part[label == sp])) == 1  # no superpoint straddles the table and the box
    assert len(np.unique(label[part == 0])) == 1  # the flat single-colour top is one superpoint
    g = superpoint_graph(pts, nrm, col, label, edges, concave, step)
    assert g.size == len(np.unique(label)) and g.count.sum() == len(pts)
    top, box = label[part == 0][0], label[part == 1][0]
    pair = np.flatnonzero((g.pairs[:, 0] == min(top, box)) & (g.pairs[:, 1] == max(top, box)))
    assert len(pair) == 1 and g.contacts[pair[0]] > 0 and g.concave[pair[0]] == g.contacts[pair[0]]
    assert g.up[top] == 1.0 and g.up[box] == 0.0
    np.testing.assert_allclose(g.lo[top, 2], 0.7)
    np.testing.assert_allclose(g.colour[box], [0.9, 0.9, 0.85])


def test_felzenszwalb_scale_and_small_components():
    # a chain of 10 nodes with one heavy edge in the middle: a small k cuts it there, a huge k does not,
    # and min_size joins a component that is too small to its cheapest neighbour
    edges = np.array([[i, i + 1] for i in range(9)])
    w = np.full(9, 0.01)
    w[4] = 1.0
    assert len(np.unique(felzenszwalb(10, edges, w, k=0.1, min_size=1))) == 2
    assert len(np.unique(felzenszwalb(10, edges, w, k=100.0, min_size=1))) == 1
    assert len(np.unique(felzenszwalb(10, edges, w, k=0.1, min_size=6))) == 1
    assert len(point_graph(np.zeros((1, 3)), 0.1)) == 0
