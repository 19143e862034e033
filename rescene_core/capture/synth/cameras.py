"""The camera walks of a synthetic capture.

'walk': a loop through the room's free space at 1.3-1.7 m looking across the room, close-ups that crop
large objects, and distant views from the corners. 'head': a head-mounted camera (``plan_head_cameras``)
walking the kitchen side of an egocentric room, looking down at the island and the worktops.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import LineString, Point
from shapely.ops import unary_union
from shapely.prepared import prep

from rescene_core.capture.synth.kitchen import KitchenLayout
from rescene_core.capture.synth.layout import Layout
from rescene_core.capture.synth.presets import SynthPreset
from rescene_core.geometry.camera import intrinsics_from_fov, look_at
from rescene_core.records import Relation, Root

CLOSEUP_LABELS = frozenset({"bed", "sofa", "wardrobe", "dining table", "desk", "chair", "cabinet", "bookshelf"})
"""Categories large enough that a close-up crops them."""


@dataclass(frozen=True)
class CameraPlan:
    """Camera poses and why each was taken: kind[t] is 'walk', 'closeup' or 'distant'.

    world_from_cam: float64 [T, 4, 4] OpenCV axes. K: float64 [3, 3]. target_object[t]: the object a
    close-up crops (0 otherwise).
    """

    world_from_cam: NDArray[np.float64]
    K: NDArray[np.float64]
    kinds: tuple[str, ...]
    target_object: tuple[int, ...]


def intrinsics(preset: SynthPreset) -> NDArray[np.float64]:
    return intrinsics_from_fov(preset.width, preset.height, preset.hfov_deg)


def _inside_object(lay: Layout, p: NDArray, margin: float) -> bool:
    pt = Point(p[0], p[1])
    for o in lay.objects:
        if o.z0 - margin <= p[2] <= o.z1 + margin and o.footprint.buffer(margin).contains(pt):
            return True
    return False


def _waypoint_loop(free, rng: np.random.Generator, spacing: float = 0.25, count: int = 9) -> LineString:
    """A closed walk through the free floor: farthest-point waypoints on a grid, visited nearest-first."""
    x0, y0, x1, y1 = free.bounds
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1e-9, spacing), np.arange(y0, y1 + 1e-9, spacing))
    cand = np.column_stack([gx.ravel(), gy.ravel()])
    pf = prep(free)
    cand = np.array([c for c in cand if pf.contains(Point(c[0], c[1]))])
    if len(cand) < 3:
        c = np.array(free.representative_point().coords[0])
        cand = c + np.array([[0.3, 0.0], [0.0, 0.3], [-0.3, 0.0], [0.0, -0.3]])
    chosen = [int(rng.integers(len(cand)))]
    dist = np.linalg.norm(cand - cand[chosen[0]], axis=1)
    for _ in range(min(count, len(cand)) - 1):
        chosen.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(cand - cand[chosen[-1]], axis=1))
    pts = cand[chosen]
    order, left = [0], set(range(1, len(pts)))
    while left:
        last = pts[order[-1]]
        nxt = min(left, key=lambda i: (float(np.linalg.norm(pts[i] - last)), i))
        order.append(nxt)
        left.remove(nxt)
    loop = [tuple(pts[i]) for i in order]
    return LineString(loop + [loop[0]])


def plan_cameras(lay: Layout, preset: SynthPreset, rng: np.random.Generator) -> CameraPlan:
    """Plan ``preset.frames`` cameras over the furnished room (see module docstring)."""
    if preset.camera == "head":
        return plan_head_cameras(lay, preset, rng)
    if preset.camera != "walk":
        raise ValueError(f"unknown camera walk {preset.camera!r}; choose 'walk' or 'head'")
    room = lay.room
    n = preset.frames
    n_close = int(round(n * preset.closeup_fraction))
    n_far = int(round(n * preset.distant_fraction))
    n_walk = n - n_close - n_far
    floor_objs = [o.footprint for o in lay.objects if o.relation == Relation.RESTS_ON and o.parent == Root.FLOOR]
    free = room.polygon.buffer(-0.4)
    if floor_objs:
        free = free.difference(unary_union(floor_objs).buffer(0.2))
    if free.is_empty or free.area < 0.2:
        free = room.polygon.buffer(-0.3)
    ring = _waypoint_loop(free, rng)
    centre = np.array(room.polygon.centroid.coords[0])
    phase0 = float(rng.uniform(0, 1))

    poses, kinds, targets = [], [], []
    walk_s = []
    for k in range(n_walk):
        s = (phase0 + k / n_walk) % 1.0
        p = np.array(ring.interpolate(s, normalized=True).coords[0])
        for j in range(1, 25):  # a straight leg may cross tall furniture: step along the loop to free floor
            if not _inside_object(lay, np.array([p[0], p[1], 1.5]), 0.15):
                break
            s2 = (s + (j // 2 + 1) * 0.004 * (1 if j % 2 else -1)) % 1.0
            p = np.array(ring.interpolate(s2, normalized=True).coords[0])
        ahead = np.array(ring.interpolate((s + 0.01) % 1.0, normalized=True).coords[0]) - p
        h = float(
            np.clip(
                np.mean(preset.walk_height) + 0.15 * np.sin(2 * np.pi * 3 * s) + rng.normal(0, 0.04),
                *preset.walk_height,
            )
        )
        to_c = centre - p
        base = np.arctan2(to_c[1], to_c[0]) if np.linalg.norm(to_c) > 1.0 else np.arctan2(ahead[1], ahead[0])
        yaw = base + np.radians(55) * np.sin(2 * np.pi * 5 * s + 1.0) + rng.normal(0, 0.1)
        pitch = np.radians(-14 + rng.normal(0, 5))
        eye = np.array([p[0], p[1], h])
        fwd = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), np.sin(pitch)])
        poses.append(look_at(eye, eye + fwd, rng.normal(0, 0.03), strict=False))
        kinds.append("walk")
        targets.append(0)
        walk_s.append(s)

    big = [o for o in lay.objects if o.label in CLOSEUP_LABELS]
    inner = room.polygon.buffer(-0.12)
    made, tries = 0, 0
    while made < n_close and big and tries < 60 * n_close:
        tries += 1
        obj = big[(made + tries) % len(big)] if tries % 3 else big[int(rng.integers(len(big)))]
        (x0, y0, _), (x1, y1, z1) = obj.model.bounds
        local = np.array([rng.uniform(x0, x1), y1, rng.uniform(0.05, 0.95) * z1, 1.0])
        if rng.uniform() < 0.3:  # a side instead of the front
            local[0], local[1] = (x0 if rng.uniform() < 0.5 else x1), rng.uniform(y0, y1)
        target = (obj.world_from_object @ local)[:3]
        out = obj.world_from_object[:3, :3] @ np.array([0.0, 1.0, 0.0])
        if local[1] != y1:
            out = obj.world_from_object[:3, :3] @ np.array([np.sign(local[0] - (x0 + x1) / 2), 0.0, 0.0])
        dist = rng.uniform(*preset.closeup_distance)
        eye = target + out * dist + np.array([rng.normal(0, 0.15), rng.normal(0, 0.15), rng.uniform(0.15, 0.6)])
        eye[2] = float(np.clip(eye[2], 0.5, room.height - 0.3))
        if not inner.contains(Point(eye[0], eye[1])) or _inside_object(lay, eye, 0.08):
            continue
        poses.append(look_at(eye, target, rng.normal(0, 0.03), strict=False))
        kinds.append("closeup")
        targets.append(obj.object_id)
        made += 1

    corners = np.array(room.polygon.buffer(-0.3, join_style=2).exterior.coords[:-1])
    made, tries = 0, 0
    while made < n_far and tries < 40 * max(1, n_far):
        tries += 1
        c = corners[int(rng.integers(len(corners)))]
        eye = np.array([c[0], c[1], rng.uniform(1.55, 1.7)])
        if _inside_object(lay, eye, 0.05):
            continue
        far = centre + (centre - c) * rng.uniform(0.0, 0.6)
        target = np.array([far[0], far[1], rng.uniform(0.4, 0.9)])
        poses.append(look_at(eye, target, rng.normal(0, 0.02), strict=False))
        kinds.append("distant")
        targets.append(0)
        made += 1

    # a real capture is one sequence: put each extra view next to the nearest walk position
    while len(poses) < n:  # close-ups or distant views that found no free spot become walk frames
        s = float(rng.uniform(0, 1))
        p = np.array(ring.interpolate(s, normalized=True).coords[0])
        eye = np.array([p[0], p[1], float(rng.uniform(*preset.walk_height))])
        poses.append(look_at(eye, np.array([centre[0], centre[1], 0.8]), strict=False))
        kinds.append("walk")
        targets.append(0)
        walk_s.append(s)
    walk_xy = np.array([pp[:2, 3] for pp, k in zip(poses, kinds) if k == "walk"])
    walk_order = np.array(walk_s)
    keys: list[tuple[float, float, int]] = []
    for pp, kind in zip(poses, kinds):
        if kind == "walk":
            keys.append((float(walk_order[len([1 for q in keys if q[2] == 0])]), 0.0, 0))
        else:
            j = int(np.argmin(np.linalg.norm(walk_xy - pp[:2, 3], axis=1)))
            keys.append((float(walk_order[j]), 1.0, 1))
    order = sorted(range(len(poses)), key=lambda i: (keys[i][0], keys[i][1], i))
    return CameraPlan(
        world_from_cam=np.stack([poses[i] for i in order]),
        K=intrinsics(preset),
        kinds=tuple(kinds[i] for i in order),
        target_object=tuple(targets[i] for i in order),
    )


def _head_path(lay: KitchenLayout, rng: np.random.Generator) -> LineString:
    """Where the wearer walks: along the aisle between the worktops and the island, round one end of the
    island, and part way along its back; waypoints that fall outside the room or inside furniture are dropped."""
    p0, u, n = lay.kitchen_axes()
    depth = max(c.model.size[1] for c in lay.counters)
    if lay.island is None:
        s_mid = float(np.mean([(c.world_from_object[:2, 3] - p0) @ u for c in lay.counters]))
        half = sum(c.model.size[0] for c in lay.counters) / 2
        local = [(s_mid - half * 0.8, depth + 0.6), (s_mid + half * 0.8, depth + 0.6), (s_mid, depth + 1.3)]
    else:
        centre = lay.island.world_from_object[:2, 3] - p0
        s_i, t_i = float(centre @ u), float(centre @ n)
        a, b = lay.island.model.size[0] / 2, lay.island.model.size[1] / 2
        t_aisle = (depth + t_i - b) / 2
        t_back = t_i + b + 0.55
        side = 1.0 if rng.uniform() < 0.5 else -1.0
        local = [
            (s_i - side * a * 0.9, t_aisle),
            (s_i + side * a * 0.6, t_aisle),
            (s_i + side * (a + 0.55), (t_aisle + t_i) / 2),
            (s_i + side * (a + 0.55), t_i + b * 0.5),
            (s_i + side * a * 0.5, t_back),
            (s_i - side * a * float(rng.uniform(0.0, 0.5)), t_back),
        ]
    inner = prep(lay.room.polygon.buffer(-0.3))
    points = []
    for s_, t_ in local:
        xy = p0 + u * s_ + n * t_
        if inner.contains(Point(xy[0], xy[1])) and not _inside_object(lay, np.array([xy[0], xy[1], 1.5]), 0.1):
            points.append(tuple(xy))
    if len(points) < 2:
        raise ValueError(f"the head-mounted walk found {len(points)} free waypoints by the kitchen; need 2")
    return LineString(points)


def _attention_point(
    lay: KitchenLayout, eye: NDArray, face_yaw: float, preset: SynthPreset, rng: np.random.Generator
) -> NDArray[np.float64]:
    """A point the wearer looks at from ``eye``: on the top of the work surface nearest to the wearer (three
    times in four, as one looks at what is at hand) or of any, within the allowed turn from facing the
    kitchen wall and at least 0.3 m away, nearer points likelier (weight 1 / distance^2); ahead at worktop
    height when none is."""
    limit = np.radians(preset.head_yaw_deg)
    here = Point(eye[0], eye[1])
    surfaces = sorted(lay.work_surfaces, key=lambda o: o.footprint.distance(here))
    options, weights = [], []
    for _ in range(16):
        host = surfaces[0] if rng.uniform() < 0.75 else surfaces[int(rng.integers(len(surfaces)))]
        sup = host.model.supports[0]
        local = np.array([rng.uniform(sup.x0, sup.x1), rng.uniform(sup.y0, sup.y1), sup.z, 1.0])
        p = (host.world_from_object @ local)[:3]
        d = p[:2] - eye[:2]
        turn = np.angle(np.exp(1j * (np.arctan2(d[1], d[0]) - face_yaw)))
        if np.linalg.norm(d) >= 0.3 and abs(turn) <= limit:
            options.append(p)
            weights.append(1.0 / float(d @ d))
    if options:
        return options[int(rng.choice(len(options), p=np.asarray(weights) / sum(weights)))]
    worktop = float(lay.counters[0].z1)
    return np.array([eye[0] + np.cos(face_yaw), eye[1] + np.sin(face_yaw), worktop])


def plan_head_cameras(lay: Layout, preset: SynthPreset, rng: np.random.Generator) -> CameraPlan:
    """A head-mounted camera walking the kitchen side of an egocentric room (``kitchen.KitchenLayout``).

    The wearer walks ``_head_path`` once at an eye height drawn in ``preset.walk_height`` (with a 2 cm bob),
    and looks at points on the island and the worktops for 5-12 frames each, turning between them over 4
    frames. The view turns at most ``head_yaw_deg`` from facing the kitchen wall (the wall behind is never
    seen), its pitch below the horizon is kept in ``head_pitch_deg`` and it rolls slowly, at most
    ``head_roll_deg``. Every frame is kind 'head'.
    """
    if not isinstance(lay, KitchenLayout) or not lay.counters:
        raise ValueError("the 'head' camera walk needs the egocentric program's kitchen (program='egocentric')")
    n = preset.frames
    path = _head_path(lay, rng)
    _, _, normal = lay.kitchen_axes()
    face_yaw = float(np.arctan2(-normal[1], -normal[0]))
    steps = np.cumsum(rng.uniform(0.6, 1.4, n))
    along = (steps - steps[0]) / max(steps[-1] - steps[0], 1e-9)
    eye_height = float(rng.uniform(*preset.walk_height))
    bob_phase, roll_phase = rng.uniform(0, 2 * np.pi, 2)
    roll_amp = float(rng.uniform(0.3, 0.8)) * preset.head_roll_deg
    roll_period = float(rng.uniform(20, 40))
    lo, hi = preset.head_pitch_deg
    poses = []
    target = previous = None
    switch, turned = 0, 0
    for k in range(n):
        xy = np.array(path.interpolate(float(along[k]), normalized=True).coords[0]) + rng.normal(0, 0.02, 2)
        h = float(np.clip(eye_height + 0.02 * np.sin(2 * np.pi * k / 6 + bob_phase), *preset.walk_height))
        eye = np.array([xy[0], xy[1], h])
        if k == switch:
            previous = target
            target = _attention_point(lay, eye, face_yaw, preset, rng)
            switch, turned = k + int(rng.integers(5, 13)), 0
        assert target is not None
        w = min(1.0, (turned + 1) / 4)
        turned += 1
        look = target if previous is None else (1 - w) * previous + w * target
        d = look - eye
        turn = np.angle(np.exp(1j * (np.arctan2(d[1], d[0]) - face_yaw)))
        yaw = face_yaw + float(np.clip(turn, -np.radians(preset.head_yaw_deg), np.radians(preset.head_yaw_deg)))
        down = np.degrees(np.arctan2(-d[2], max(float(np.linalg.norm(d[:2])), 1e-6)))
        pitch = np.radians(float(np.clip(down + rng.normal(0, 2.0), lo, hi)))
        roll = float(
            np.clip(
                roll_amp * np.sin(2 * np.pi * k / roll_period + roll_phase) + rng.normal(0, 1.5),
                -preset.head_roll_deg,
                preset.head_roll_deg,
            )
        )
        fwd = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)])
        poses.append(look_at(eye, eye + fwd, np.radians(roll), strict=False))
    return CameraPlan(world_from_cam=np.stack(poses), K=intrinsics(preset), kinds=("head",) * n, target_object=(0,) * n)
