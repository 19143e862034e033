"""The egocentric preset's room: a kitchen with a living corner, furnished for a head-mounted walk.

One of the room's two longest walls is the kitchen wall: a run of base units ("kitchen counter") stands
against it, wall cabinets ("cabinet/wardrobe part") hang above the run, and a kitchen island stands free in
front of it across a 0.95-1.2 m aisle, bar stools at its overhang. Bowls, cups, jars, cutting boards and a
tray with things on it stand on the island and the worktops (some under 10 cm). The rest of the room is a
living corner built by the furnished program's own placements (a sofa, a shelf, a dining table with chairs,
a TV and pictures on the walls), which the head-mounted walk mostly never sees. Every placement goes through
``Layout``'s overlap checks, so the ground truth has no interpenetration.
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import Polygon

from rescene_core.capture.synth.kitchen_objects import kitchen_counter, upper_cabinet
from rescene_core.capture.synth.layout import Layout, Placed, Room, build, footprint, pose2d
from rescene_core.capture.synth.presets import SynthPreset
from rescene_core.records import Relation, Root, WallPlane

AISLE = (0.95, 1.2)
"""Free width between the worktops' front and the island (m)."""
WALL_CABINET_GAP = (0.5, 0.58)
"""Height of the wall cabinets' bottom above the worktop (m)."""
ISLAND_CLUTTER = ("tray", "cutting board", "bowl", "coffee cup", "crème jar", "spice jar")
"""What is put on the island, in this order, while the object budget lasts."""
COUNTER_CLUTTER = ("crème jar", "spice jar", "bowl", "cutting board", "coffee cup", "small plant")
"""What is put on the worktops, in this order, while the object budget lasts."""
ON_TRAY = ("coffee cup", "spice jar")
"""What stands on the tray (rests on the tray, which rests on the island)."""


class KitchenLayout(Layout):
    """A ``Layout`` that also says where the kitchen is: the wall the counters back onto, the island, the
    base units and the wall cabinets (the head-mounted walk looks at them)."""

    def __init__(self, room: Room, preset: SynthPreset, rng: np.random.Generator):
        super().__init__(room, preset, rng)
        self.kitchen_wall: WallPlane = room.walls[0]
        self.island: Placed | None = None
        self.counters: list[Placed] = []
        self.wall_cabinets: list[Placed] = []

    def kitchen_axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(origin, along, into the room) of the kitchen wall: its first end, its unit direction and its
        inward unit normal, world xy (m)."""
        p0, u, n, _, _ = self._wall_frame(self.kitchen_wall)
        return p0, u, n

    @property
    def work_surfaces(self) -> list[Placed]:
        """The island and the base units: the raised supports the walk attends to."""
        return ([self.island] if self.island is not None else []) + self.counters

    def door_away_from(self, wall: WallPlane, tries: int = 20) -> None:
        """A door on another wall than ``wall`` whose swing area is clear of the furniture placed so far; the
        area is kept free of the floor furniture placed later."""
        others = [w for w in self.room.walls if w.id != wall.id]
        for _ in range(tries):
            door_wall = others[int(self.rng.integers(len(others)))]
            p0, u, n, length, _ = self._wall_frame(door_wall)
            if length < 1.4:
                continue
            s = float(self.rng.uniform(0.5, length - 0.5))
            a, b = p0 + u * (s - 0.45), p0 + u * (s + 0.45)
            swing = Polygon([a, b, b + n * 0.9, a + n * 0.9])
            if not any(o.z0 < 0.05 and swing.intersects(o.footprint) for o in self.objects):
                self.keepout.append(swing)
                self.door = (door_wall.id, s)
                return

    def kitchen_run(self, wall: WallPlane, widths: list[float], height: float, clearance: float) -> list[Placed]:
        """Base units side by side against ``wall`` (backs to it), 4 mm apart, at a random place along it."""
        members = [
            (kitchen_counter(self.rng, w, height, clearance), 0.0 if k == 0 else 0.004) for k, w in enumerate(widths)
        ]
        return self.against_wall(members, wall_ids=[wall.id], tries=30) or []

    def wall_cabinets_over(self, run: list[Placed], bottom: float) -> list[Placed]:
        """One wall cabinet hung over each base unit of ``run``, its bottom at ``bottom`` (m); of three units,
        one is left without (the hood's place)."""
        wall = self.kitchen_wall
        p0, u, _, _, _ = self._wall_frame(wall)
        skip = int(self.rng.integers(len(run))) if len(run) >= 3 else -1
        height = float(self.rng.uniform(0.6, 0.75))
        height = min(height, self.room.height - 0.1 - bottom)
        out = []
        if height < 0.4:
            return out
        for k, unit in enumerate(run):
            if k == skip:
                continue
            model = upper_cabinet(self.rng, unit.model.size[0] - 0.01, height)
            s = float((unit.world_from_object[:2, 3] - p0) @ u)
            pose = self.wall_pose(model, wall, s, bottom)
            if self.free(footprint(model, pose), bottom, bottom + height, 0.0):
                out.append(self._add(model, pose, Relation.MOUNTS_ON, Root.WALL, wall.id))
        return out

    def island_facing(self, run: list[Placed], tries: int = 20) -> Placed | None:
        """The island in front of the run across the aisle, its doors (+y) toward the run."""
        wall = self.kitchen_wall
        p0, u, n, _, yaw = self._wall_frame(wall)
        along = [float((c.world_from_object[:2, 3] - p0) @ u) for c in run]
        depth = max(c.model.size[1] for c in run)
        centre = float(np.mean(along))
        for k in range(tries):
            model = build("kitchen island", self.rng)
            aisle = float(self.rng.uniform(*AISLE)) if k < tries // 2 else AISLE[0]
            dist = self.preset.contact_gap + depth + aisle + model.size[1] / 2
            s = centre + float(self.rng.uniform(-0.25, 0.25))
            xy = p0 + u * s + n * dist
            pose = pose2d(xy[0], xy[1], yaw + np.pi)
            if self.free(footprint(model, pose), 0.0, model.size[2], 0.3):
                return self._add(model, pose, Relation.RESTS_ON, Root.FLOOR, None)
        return None

    def stools_at(self, island: Placed, count: int) -> list[Placed]:
        """Bar stools along the island's back (its -y side, under the worktop's overhang's edge)."""
        out = []
        (x0, y0, _), (x1, _, _) = island.model.bounds
        for k in range(count):
            model = build("bar stool", self.rng)
            x = x0 + (x1 - x0) * (k + 1) / (count + 1) + float(self.rng.uniform(-0.05, 0.05))
            # turned at most 0.15 rad from the island's axes: its footprint grows by under 15 %
            local = np.array([x, y0 - 0.05 - 0.58 * model.size[1], 0.0, 1.0])
            world = island.world_from_object @ local
            island_yaw = float(np.arctan2(island.world_from_object[1, 0], island.world_from_object[0, 0]))
            pose = pose2d(world[0], world[1], island_yaw + float(self.rng.uniform(-0.15, 0.15)))
            if self.free(footprint(model, pose), 0.0, model.size[2], 0.02):
                out.append(self._add(model, pose, Relation.RESTS_ON, Root.FLOOR, None))
        return out


def furnish_kitchen(room: Room, preset: SynthPreset, rng: np.random.Generator) -> KitchenLayout:
    """The kitchen (counters, wall cabinets, island, stools, clutter), then the living corner, up to a number
    of objects drawn from ``preset.objects``."""
    lay = KitchenLayout(room, preset, rng)
    target = int(rng.integers(preset.objects[0], preset.objects[1] + 1))

    def full() -> bool:
        return len(lay.objects) >= target

    longest = sorted(room.walls, key=lambda w: -float(np.linalg.norm(np.subtract(w.segment[1], w.segment[0]))))
    lay.kitchen_wall = longest[int(rng.integers(2))]
    wall_len = float(np.linalg.norm(np.subtract(lay.kitchen_wall.segment[1], lay.kitchen_wall.segment[0])))
    run_len = min(float(rng.uniform(2.4, 3.6)), wall_len - 0.4)
    n_units = 3 if run_len > 2.6 else 2
    shares = rng.uniform(0.8, 1.2, n_units)
    widths = [float(w) for w in shares / shares.sum() * run_len]
    worktop = float(rng.uniform(0.88, 0.92))
    gap = float(rng.uniform(*WALL_CABINET_GAP))
    lay.counters = lay.kitchen_run(lay.kitchen_wall, widths, worktop, gap - 0.02)
    if not lay.counters:
        raise RuntimeError(f"no room for a {run_len:.2f} m kitchen run on wall {lay.kitchen_wall.id}")
    lay.wall_cabinets = lay.wall_cabinets_over(lay.counters, worktop + gap)
    lay.island = lay.island_facing(lay.counters)
    lay.door_away_from(lay.kitchen_wall)
    if lay.island is not None:
        lay.stools_at(lay.island, int(rng.integers(1, 4)))

    # clutter on the island (what the walk looks at most)
    if lay.island is not None:
        for name in ISLAND_CLUTTER:
            if full():
                break
            placed = lay.on(lay.island, build(name, rng), facing=name in ("tray", "cutting board"))
            if placed is not None and placed.label == "tray":
                for small in ON_TRAY:
                    if not full():
                        lay.on(placed, build(small, rng))

    # the living corner, with the furnished program's placements, on the other walls
    others = [w.id for w in room.walls if w.id != lay.kitchen_wall.id]
    if not full():
        lay.against_wall([(build("sofa", rng), 0.0)], wall_ids=others)
    if not full():
        lay.against_wall([(build("bookshelf", rng), 0.0)], corner=True, wall_ids=others)
    if not full():
        table = lay.free_standing(build("dining table", rng), margin=0.5)
        if table is not None and not full():
            lay.around(table, [build("chair", rng) for _ in range(min(2, target - len(lay.objects)))])
    for name, z_range in (("TV", (0.9, 1.2)), ("picture", (1.2, 1.6))):
        if not full():
            lay.on_wall(build(name, rng), z_range)

    # then the worktops
    for k, name in enumerate(COUNTER_CLUTTER):
        if full():
            break
        lay.on(lay.counters[k % len(lay.counters)], build(name, rng), facing=name == "cutting board")

    # fill the budget with small things on the work surfaces
    fillers = ("coffee cup", "spice jar", "bowl", "crème jar")
    k = 0
    while not full() and k < 30:
        host = lay.work_surfaces[k % len(lay.work_surfaces)]
        lay.on(host, build(fillers[k % len(fillers)], rng))
        k += 1
    return lay
