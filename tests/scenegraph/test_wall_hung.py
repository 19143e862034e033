"""Things against a wall and what is under them, per frame (the geometric backend's rules on hand-made
points): a wall shelf hung 2 cm above a monitor standing in front of the wall hangs on the wall, and a spice
jar at the back of a counter stands on the counter."""

import numpy as np

from rescene_core.config import SceneGraphConfig
from rescene_core.records import Relation, Root
from rescene_core.scenegraph.geom import heights, lower_surface, upward_mask
from rescene_core.scenegraph.geometric import GeometricPredictor, compact_on_a_wall
from tests.scenegraph.room import SIZE, room_shell

CFG = SceneGraphConfig().geometric


def _box_faces(lo, hi, n: int, rng, faces=("top", "front")) -> np.ndarray:
    """n points per face on the top and the front (y = lo[1], facing the room) of the box [lo, hi] (m)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    out = []
    if "top" in faces:
        out.append(np.c_[rng.uniform(lo[0], hi[0], n), rng.uniform(lo[1], hi[1], n), np.full(n, hi[2])])
    if "front" in faces:
        out.append(np.c_[rng.uniform(lo[0], hi[0], n), np.full(n, lo[1]), rng.uniform(lo[2], hi[2], n)])
    if "bottom" in faces:
        out.append(np.c_[rng.uniform(lo[0], hi[0], n), rng.uniform(lo[1], hi[1], n), np.full(n, lo[2])])
    return np.vstack(out)


def _decide(points: dict[int, np.ndarray], who: int):
    shell = room_shell()
    h = {d: heights(shell, p) for d, p in points.items()}
    bottom = {d: lower_surface(h[d]) for d in points}
    up = {d: upward_mask(p, shell, CFG.normal_neighbours, CFG.upward_normal_deg) for d, p in points.items()}
    occluded = {d: False for d in points}
    return GeometricPredictor._decide(who, points, h, up, bottom, occluded, shell, CFG)


def test_a_wall_shelf_just_above_a_monitor_hangs_on_the_wall():
    # the y = SIZE wall; a monitor 0.45 m tall whose top (1.225 m) lies 0.13-0.25 m in front of the wall, on a
    # desk; a wall shelf 0.22 m deep, its back 2 cm off the wall and its underside 2 cm above the monitor
    rng = np.random.default_rng(0)
    desk = _box_faces((1.2, SIZE - 0.7, 0.0), (2.6, SIZE, 0.77), 1500, rng)
    monitor = _box_faces((1.6, SIZE - 0.25, 0.775), (2.3, SIZE - 0.13, 1.225), 800, rng)
    shelf = _box_faces((1.5, SIZE - 0.24, 1.245), (2.4, SIZE - 0.02, 1.415), 800, rng, ("top", "front", "bottom"))
    points = {1: desk, 2: monitor, 3: shelf}
    assert _decide(points, 3) == (Relation.MOUNTS_ON.value, Root.WALL.value)
    assert _decide(points, 2) == (Relation.RESTS_ON.value, 1)  # the monitor stands on the desk


def test_a_spice_jar_at_the_back_of_a_counter_stands_on_it():
    # a counter 0.9 m tall reaching the wall; a spice jar 4 x 4 x 9 cm, its back 1 cm off the wall: flat
    # against the wall and taller than twice its depth, yet smaller than anything hung on a wall
    rng = np.random.default_rng(1)
    counter = _box_faces((1.0, SIZE - 0.6, 0.0), (2.5, SIZE, 0.9), 2000, rng)
    keep = ~((counter[:, 0] > 1.48) & (counter[:, 0] < 1.52) & (counter[:, 1] > SIZE - 0.05) & (counter[:, 2] > 0.89))
    counter = counter[keep]  # hidden under the jar
    jar = _box_faces((1.48, SIZE - 0.05, 0.9), (1.52, SIZE - 0.01, 0.99), 300, rng)
    assert compact_on_a_wall(jar, room_shell())
    assert _decide({1: counter, 2: jar}, 2) == (Relation.RESTS_ON.value, 1)
