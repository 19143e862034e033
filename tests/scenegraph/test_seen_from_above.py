"""Supports seen only from above: a head-mounted camera looking down at a kitchen island sees its top and
nothing below it, so the island's lowest visible point is its top, at the bottom of the things on it.

A support is judged by its top surface around the child (``geom.holds_from_below``), not by its lowest
visible point; a large horizontal top at counter height with nothing seen below stands on the floor
(``geom.seen_only_from_above``); and nothing rests on a thing more than ``support_gap`` below it (an upper
cabinet above a cup).
"""

from __future__ import annotations

import numpy as np
import pytest

from rescene_core.capture import open_capture, write_capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import InstanceId, Plane, Relation, RoomShell, Root, WallPlane
from rescene_core.scenegraph import fuse_with_report, make_predictor, predict_frames
from rescene_core.scenegraph.geom import (
    heights,
    holds_from_below,
    lower_surface,
    near_footprint,
    seen_only_from_above,
    upward_mask,
)
from rescene_core.scenegraph.geometric import GeometricPredictor, compact_on_a_wall, flat_on_a_wall
from rescene_core.scenegraph.priors import floor_contact, instance_geometry, object_support
from tests.fixtures import Box, box_capture_arrays, look_at, pinhole

CFG = SceneGraphConfig()
ISLAND, CUP, BOWL, TRAY, CABINET = 3, 4, 5, 6, 7
TOP = 0.90  # the island's top (m)
# a 4 x 4 m kitchen whose one seen wall is y = 0 (normal +y); the island stands 10 cm off it
SHELL = RoomShell(
    Plane((0.0, 0.0, 1.0), 0.0),
    (WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (4.0, 0.0))),),
    ((0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)),
    2.6,
)
# id: (label, structural, extents (x, y, z), centre); the island is only its top, a 2 cm slab at 0.9 m,
# as a camera looking down at it reconstructs it; the cup stands under the upper cabinet, 0.5 m below it
BOXES = {
    1: ("floor", True, (4.0, 4.0, 0.02), (2.0, 2.0, -0.01)),
    2: ("wall", True, (4.0, 0.02, 2.6), (2.0, -0.01, 1.3)),
    ISLAND: ("kitchen island", False, (1.2, 0.8, 0.02), (1.6, 0.5, TOP - 0.01)),
    CUP: ("cup", False, (0.08, 0.08, 0.10), (1.5, 0.25, TOP + 0.05)),
    BOWL: ("bowl", False, (0.16, 0.16, 0.07), (1.9, 0.6, TOP + 0.035)),
    TRAY: ("tray", False, (0.40, 0.30, 0.02), (1.2, 0.6, TOP + 0.01)),
    CABINET: ("upper cabinet", False, (0.8, 0.35, 0.7), (1.6, 0.175, 1.85)),
}
WANT = {
    ISLAND: (Relation.RESTS_ON, Root.FLOOR),
    CUP: (Relation.RESTS_ON, InstanceId(ISLAND)),
    BOWL: (Relation.RESTS_ON, InstanceId(ISLAND)),
    TRAY: (Relation.RESTS_ON, InstanceId(ISLAND)),
    CABINET: (Relation.MOUNTS_ON, Root.WALL),
}


def kitchen_arrays():
    """The kitchen seen by a head at 1.6 m standing in front of the island, pitched 20-35 deg down."""
    rng = np.random.default_rng(0)
    placed = [
        Box.centred(iid, label, centre, extents, rng.integers(40, 230, 3), structural)
        for iid, (label, structural, extents, centre) in BOXES.items()
    ]
    poses = [
        look_at(np.array([x, 1.8, 1.6]), np.array([x + dx, 0.3, z]))
        for x, dx, z in ((1.3, 0.2, 0.95), (1.6, 0.0, 1.05), (1.9, -0.2, 0.9), (1.6, 0.1, 0.8))
    ]
    return box_capture_arrays(placed, np.asarray(poses), pinhole(160, 120, 110.0), 160, 120, points="depth")


@pytest.fixture(scope="module")
def kitchen(tmp_path_factory):
    path = tmp_path_factory.mktemp("kitchen") / "kitchen.zarr"
    write_capture(path, kitchen_arrays())
    return open_capture(path)


@pytest.fixture(scope="module")
def predictions(kitchen):
    return predict_frames(kitchen, list(range(kitchen.num_frames)), SHELL, CFG, make_predictor(CFG))


def test_the_island_is_seen_only_from_its_top(kitchen):
    """The premise: the island's lowest visible point is within a few cm of the cup's bottom, so a rule by
    the parent's lowest point (``parent.bottom < child.bottom - support_tol``) never offers it."""
    island = instance_geometry(kitchen, ISLAND, SHELL, CFG)
    cup = instance_geometry(kitchen, CUP, SHELL, CFG)
    assert island.bottom == pytest.approx(TOP - 0.02, abs=0.015)
    assert not island.bottom < cup.bottom - CFG.geometric.support_tol
    assert island.top_only


def test_each_frame_puts_the_things_on_the_island_and_the_cabinet_on_the_wall(predictions):
    shown = 0
    for pred in predictions:
        assert pred.status == "ok"
        for v in pred.visible:
            shown += 1
            assert pred.relations[v.instance] == WANT[int(v.instance)], (pred.frame, v.label)
    assert shown >= 3 * len(WANT)


def test_fusion_keeps_the_things_on_the_island(kitchen, predictions):
    graph, report = fuse_with_report(predictions, kitchen, SHELL, CFG)
    assert graph.check() == []
    got = {int(e.child): (e.relation, e.parent) for e in graph.edges}
    assert got == WANT
    by_child = graph.parent_of()
    for child in (CUP, BOWL, TRAY):
        assert by_child[InstanceId(child)].scores["G"] > 0.5  # the island's top under it, in contact
    # the island stands on the floor although its base was never seen
    assert by_child[InstanceId(ISLAND)].scores["G"] > 0.9


def test_the_support_prior_measures_the_top_and_the_gap(kitchen):
    g = {i: instance_geometry(kitchen, i, SHELL, CFG) for i in (ISLAND, CUP, BOWL, TRAY, CABINET)}
    assert object_support(g[CUP], g[ISLAND], CFG) > 0.5
    assert object_support(g[TRAY], g[ISLAND], CFG) > 0.5
    # 0.5 m of free space between the cup's top and the cabinet's bottom, and a cup is no support from above
    assert object_support(g[CABINET], g[CUP], CFG) == 0.0
    assert object_support(g[CABINET], g[ISLAND], CFG) == 0.0
    assert object_support(g[CUP], g[CABINET], CFG) == 0.0
    # the island's floor contact: its base out of view, not absent; the cup's is 0.9 m up
    assert floor_contact(g[ISLAND], CFG) > 0.9
    assert floor_contact(g[CUP], CFG) == pytest.approx(0.0, abs=1e-6)


def _decide(pts: dict[int, np.ndarray], shell: RoomShell) -> dict[int, tuple]:
    cfg = CFG.geometric
    h = {d: heights(shell, p) for d, p in pts.items()}
    bottom = {d: lower_surface(h[d]) for d in pts}
    up = {d: upward_mask(p, shell, cfg.normal_neighbours, cfg.upward_normal_deg) for d, p in pts.items()}
    return {d: GeometricPredictor._decide(d, pts, h, up, bottom, {}, shell, cfg) for d in pts}


def _box_faces(lo, hi, n: int, rng, faces=("top", "front")) -> np.ndarray:
    """n points on each named face of the box [lo, hi] (front: the y = hi[1] face)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    out = []
    for face in faces:
        p = rng.uniform(lo, hi, size=(n, 3))
        if face == "top":
            p[:, 2] = hi[2]
        elif face == "front":
            p[:, 1] = hi[1]
        out.append(p)
    return np.vstack(out)


def test_per_frame_rule_on_points_only_on_the_island_top():
    """The island as the real head-mounted capture had it: points only on its top at 0.9 m."""
    rng = np.random.default_rng(3)
    island = np.c_[rng.uniform(1.0, 2.2, 4000), rng.uniform(0.1, 0.9, 4000), np.full(4000, TOP)]
    island = island[~((np.abs(island[:, 0] - 1.5) < 0.05) & (np.abs(island[:, 1] - 0.25) < 0.05))]  # under the cup
    pts = {
        1: island,
        2: _box_faces((1.46, 0.21, TOP + 0.01), (1.54, 0.29, TOP + 0.10), 300, rng),  # cup, its bottom 1 cm up
        3: _box_faces((1.82, 0.52, TOP), (1.98, 0.68, TOP + 0.07), 400, rng),  # bowl
        4: _box_faces((1.0, 0.45, TOP), (1.4, 0.75, TOP + 0.02), 600, rng),  # tray
        5: _box_faces((1.2, 0.0, 1.5), (2.0, 0.35, 2.2), 1500, rng, faces=("front",)),  # upper cabinet's doors
    }
    got = _decide(pts, SHELL)
    assert got[1] == ("rests-on", "floor")
    assert got[2] == got[3] == got[4] == ("rests-on", 1)
    assert got[5] == ("mounts-on", "wall")
    # with its wall not observed (the room shell has only the floor), the cabinet still rests on nothing
    # 0.5 m below it
    floor_only = RoomShell(SHELL.floor, (), SHELL.floor_polygon, 2.6)
    assert _decide(pts, floor_only)[5][1] not in (1, 2, 3, 4)


def test_a_neighbour_on_the_same_surface_is_no_support():
    """Beside a lamp on a table, a 10 cm box starts at the lamp's bottom and rises above it, and a 2 cm
    tray's top is at the lamp's bottom but not under the lamp's centre; the table's top is both."""
    rng = np.random.default_rng(4)
    lamp = rng.uniform((1.0, 1.0, 0.75), (1.1, 1.1, 1.2), size=(500, 3))
    box = rng.uniform((1.12, 1.0, 0.75), (1.3, 1.1, 0.85), size=(500, 3))
    tray = rng.uniform((1.12, 0.9, 0.75), (1.5, 1.2, 0.77), size=(500, 3))
    top = np.c_[rng.uniform(0.8, 1.6, 500), rng.uniform(0.8, 1.4, 500), np.full(500, 0.75)]
    b = lower_surface(lamp[:, 2])
    tol = CFG.geometric.support_tol
    for other, holds in ((box, False), (tray, False), (top, True)):
        around = near_footprint(other, lamp[:, :2], CFG.geometric.support_radius)
        assert around.any()
        assert holds_from_below(other, other[:, 2], lower_surface(other[:, 2]), around, lamp[:, :2], b, tol) is holds


def test_a_tray_holds_the_cup_on_it_despite_the_cup_outline_bled_into_its_mask():
    """A 2 cm tray seen from above starts 2 cm below the cup on it; 2% of its points are the cup's outline
    (mask bleed at their shared border), up to the cup's top."""
    rng = np.random.default_rng(5)
    cup = rng.uniform((1.16, 1.16, 0.77), (1.24, 1.24, 0.87), size=(400, 3))
    tray_top = np.c_[rng.uniform(1.0, 1.4, 1500), rng.uniform(1.0, 1.3, 1500), np.full(1500, 0.77)]
    bleed = rng.uniform((1.15, 1.15, 0.77), (1.25, 1.25, 0.87), size=(30, 3))
    tray = np.vstack([tray_top, rng.uniform((1.0, 1.0, 0.75), (1.4, 1.3, 0.77), size=(100, 3)), bleed])
    around = near_footprint(tray, cup[:, :2], CFG.geometric.support_radius)
    assert tray[around, 2].max() > lower_surface(cup[:, 2]) + CFG.geometric.support_tol  # the bleed rises above
    assert holds_from_below(
        tray,
        tray[:, 2],
        lower_surface(tray[:, 2]),
        around,
        cup[:, :2],
        lower_surface(cup[:, 2]),
        CFG.geometric.support_tol,
    )


def test_only_a_large_top_at_counter_height_is_taken_for_a_counter():
    rng = np.random.default_rng(6)

    def top(x, y, z, n=3000):
        return np.c_[rng.uniform(0, x, n), rng.uniform(0, y, n), np.full(n, z)]

    def counter(p):
        return seen_only_from_above(p[:, 2], p[:, :2])

    assert counter(top(1.2, 0.8, 0.9))  # an island's top
    assert counter(top(0.6, 0.6, 0.72))  # a small table's
    assert not counter(top(1.2, 0.8, 0.4))  # a coffee table's height: its base is in view from above
    assert not counter(top(0.8, 0.28, 1.0))  # a wall shelf
    assert not counter(top(0.4, 0.3, 0.92))  # a tray
    # a stack of books, 0.25 m across, whose stray points stretch its rectangle to 0.6 m
    books = np.vstack([rng.uniform((0, 0, 0.75), (0.25, 0.2, 0.85), (3000, 3)), top(0.6, 0.6, 0.8, 20)])
    assert not counter(books)
    # a base cabinet seen from the front: its front face reaches far below its top
    front = np.c_[rng.uniform(0, 1.2, 3000), np.zeros(3000), rng.uniform(0.1, 0.9, 3000)]
    assert not counter(np.vstack([top(1.2, 0.6, 0.9), front]))


def test_a_jar_at_the_back_of_a_counter_rests_on_it_and_a_picture_above_one_hangs():
    """A jar as deep as it is wide, standing against the wall on a counter, lies flat against the wall by
    the bulk of its points; being compact, it hangs there only when nothing beneath holds it. A picture
    2 cm above the counter is wide, not compact: it hangs whatever is beneath it."""
    rng = np.random.default_rng(7)
    counter = _box_faces((0.4, 0.0, 0.0), (1.6, 0.6, TOP), 3000, rng)  # top and front, seen down to the floor
    jar = _box_faces((1.0, 0.0, TOP), (1.08, 0.08, TOP + 0.12), 400, rng)
    picture = _box_faces((0.5, 0.0, TOP + 0.02), (0.9, 0.02, TOP + 0.32), 800, rng)
    assert compact_on_a_wall(jar, SHELL) and flat_on_a_wall(jar, SHELL, CFG.geometric)
    assert not compact_on_a_wall(picture, SHELL) and flat_on_a_wall(picture, SHELL, CFG.geometric)
    got = _decide({1: counter, 2: jar, 3: picture}, SHELL)
    assert got[1] == ("rests-on", "floor")
    assert got[2] == ("rests-on", 1)
    assert got[3] == ("mounts-on", "wall")
    assert _decide({2: jar}, SHELL)[2] == ("mounts-on", "wall")  # nothing beneath holds it
