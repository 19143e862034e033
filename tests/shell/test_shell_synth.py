"""Room shell on synthetic captures with strong depth noise: one estimated wall per ground-truth wall, and the
floor polygon's edges on the wall planes (so an object flush against a wall is inside the room)."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.capture.synth import write_synth
from rescene_core.shell import estimate_shell

NOISE = 0.008
"""depth_noise_quadratic of the captures (m / m^2): walls 3 m away come out as slabs about +-0.1 m thick."""


@pytest.mark.parametrize("shape", ["rect", "L"])
def test_polygon_edges_lie_on_the_walls(tmp_path, shape):
    path = write_synth(tmp_path / f"{shape}.zarr", "tiny", 0, room_shapes=(shape,), depth_noise_quadratic=NOISE)
    cap = open_capture(path, validate=False)
    gt = read_ground_truth(cap)
    shell = estimate_shell(cap)
    poly = Polygon(shell.floor_polygon)
    gt_poly = gt.shell.polygon()
    assert poly.is_valid and poly.exterior.is_ccw
    assert poly.intersection(gt_poly).area / poly.union(gt_poly).area >= 0.97
    assert len(shell.walls) == len(gt.shell.walls)  # no duplicate planes of one wall
    assert len(shell.floor_polygon) == len(gt.shell.floor_polygon)  # no spikes or notches
    ring = poly.exterior
    for gw in gt.shell.walls:
        gn = np.asarray(gw.plane.normal[:2])
        a, b = (np.asarray(p) for p in gw.segment)
        mid = 0.5 * (a + b)
        parallel = [w for w in shell.walls if np.dot(w.plane.normal[:2], gn) >= np.cos(np.radians(5))]
        assert parallel, f"no estimated wall parallel to ground-truth wall {gw.id}"
        est = min(parallel, key=lambda w: abs(np.dot(w.plane.normal[:2], mid) + w.plane.offset))
        en = np.asarray(est.plane.normal[:2])
        assert abs(np.dot(en, mid) + est.plane.offset) <= 0.03, f"wall {gw.id} plane off by more than 3 cm"
        # the polygon edge along the wall (nearest boundary points to the wall's footprint) lies on its plane
        for t in np.linspace(0.15, 0.85, 8):
            p = a + t * (b - a)
            q = ring.interpolate(ring.project(Point(p)))
            assert abs(np.dot(en, [q.x, q.y]) + est.plane.offset) <= 0.02, f"polygon leaves wall {gw.id} at {p}"
