"""Rooms and rule-based furniture placement with ground-truth support relations.

The room is a rectangle or an L, walls 2.4-3.0 m high. Floor furniture stands with its back against a
wall (beds with nightstands, wardrobes in corners, desks with a chair in front, sofas, shelves, cabinets),
or free in the room (a dining table with chairs). Small objects rest on support surfaces of other objects
(a lamp on a nightstand, a monitor on a desk, books on a shelf), and flat objects mount on walls. Every
candidate pose is checked against everything already placed (footprint overlap and height ranges), so
the ground truth has no interpenetration.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon, box
from shapely.prepared import prep

from rescene_core.capture.synth.builder import ObjectModel, Support
from rescene_core.capture.synth.objects import CATEGORIES, book_stack
from rescene_core.capture.synth.presets import SynthPreset
from rescene_core.records import Plane, Relation, RoomShell, Root, WallPlane


@dataclass
class Room:
    """Floor polygon (counter-clockwise, metres), wall height, and one wall per polygon edge."""

    polygon: Polygon
    height: float
    walls: tuple[WallPlane, ...]

    def shell(self) -> RoomShell:
        return RoomShell(
            floor=Plane((0.0, 0.0, 1.0), 0.0),
            walls=self.walls,
            floor_polygon=tuple((float(x), float(y)) for x, y in list(self.polygon.exterior.coords)[:-1]),
            ceiling_height=float(self.height),
        )


@dataclass
class Placed:
    """An object in the room: model, pose, support relation, and its footprint for collision checks."""

    object_id: int
    model: ObjectModel
    world_from_object: NDArray[np.float64]
    relation: Relation
    parent: int | Root
    wall_id: int | None
    footprint: Polygon
    z0: float
    z1: float
    ancestors: frozenset[int] = frozenset()
    top_limit: float = np.inf
    """Highest world z the object and anything stacked on it may reach (a shelf board above, the ceiling)."""
    children_on: dict[int, list[Polygon]] = field(default_factory=dict)

    @property
    def label(self) -> str:
        return self.model.label


def random_room(rng: np.random.Generator, preset: SynthPreset) -> Room:
    """A rectangular or L-shaped room; its origin is the floor corner at min x, min y."""
    w = float(rng.uniform(*preset.room_width))
    d = float(rng.uniform(*preset.room_depth))
    shape = preset.room_shapes[int(rng.integers(len(preset.room_shapes)))]
    if shape == "L":
        w, d = w * 1.15, d * 1.15
        cw, cd = w * float(rng.uniform(0.3, 0.45)), d * float(rng.uniform(0.3, 0.45))
        pts = [(0, 0), (w, 0), (w, d - cd), (w - cw, d - cd), (w - cw, d), (0, d)]
    else:
        pts = [(0, 0), (w, 0), (w, d), (0, d)]
    pts = [(round(float(x), 4), round(float(y), 4)) for x, y in pts]
    poly = Polygon(pts)
    walls = []
    for k in range(len(pts)):
        p0, p1 = np.array(pts[k]), np.array(pts[(k + 1) % len(pts)])
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        n = np.array([-u[1], u[0]])
        walls.append(
            WallPlane(
                k,
                Plane((float(n[0]), float(n[1]), 0.0), float(-n @ p0)),
                (tuple(map(float, p0)), tuple(map(float, p1))),
            )
        )
    return Room(poly, float(rng.uniform(*preset.ceiling)), tuple(walls))


def pose2d(x: float, y: float, yaw: float, z: float = 0.0) -> NDArray[np.float64]:
    """A rigid 4x4 transform: rotation by ``yaw`` about z, then translation (x, y, z)."""
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = [x, y, z]
    return out


def footprint(model: ObjectModel, world_from_object: NDArray) -> Polygon:
    """The object's bounding-box footprint on the floor (world xy), a shapely polygon."""
    (x0, y0, _), (x1, y1, _) = model.bounds
    corners = np.array([[x0, y0, 0, 1], [x1, y0, 0, 1], [x1, y1, 0, 1], [x0, y1, 0, 1]]) @ world_from_object.T
    return Polygon(corners[:, :2])


class Layout:
    """Places objects one by one, keeping every accepted pose free of overlaps."""

    def __init__(self, room: Room, preset: SynthPreset, rng: np.random.Generator):
        self.room = room
        self.preset = preset
        self.rng = rng
        self.objects: list[Placed] = []
        self.inner = prep(room.polygon.buffer(-1e-4))
        self.keepout: list[Polygon] = []
        self.door: tuple[int, float] | None = None
        """(wall id, position along the wall) of the door whose swing area stays free, once placed."""

    # -- checks ------------------------------------------------------------------------------------------

    def free(self, fp: Polygon, z0: float, z1: float, clearance: float, ignore: frozenset[int] = frozenset()) -> bool:
        if not self.inner.contains(fp) or z1 > self.room.height - 0.05:
            return False
        grown = fp.buffer(clearance, join_style=2) if clearance > 0 else fp
        if z0 < 0.05 and any(grown.intersects(k) for k in self.keepout):
            return False
        for other in self.objects:
            if other.object_id in ignore:
                continue
            if z1 <= other.z0 + 1e-6 or z0 >= other.z1 - 1e-6:
                continue
            if grown.intersects(other.footprint) and grown.intersection(other.footprint).area > 1e-9:
                return False
        return True

    def _add(self, model, pose, relation, parent, wall_id, ancestors=frozenset(), z0=None) -> Placed:
        fp = footprint(model, pose)
        z = pose[2, 3] if z0 is None else z0
        placed = Placed(
            len(self.objects) + 1,
            model,
            pose,
            relation,
            parent,
            wall_id,
            fp,
            float(z),
            float(z + model.size[2]),
            ancestors,
        )
        self.objects.append(placed)
        return placed

    # -- against walls -----------------------------------------------------------------------------------

    def _wall_frame(self, wall: WallPlane):
        p0, p1 = np.array(wall.segment[0]), np.array(wall.segment[1])
        length = float(np.linalg.norm(p1 - p0))
        u = (p1 - p0) / length
        n = np.array(wall.plane.normal[:2])
        return p0, u, n, length, float(np.arctan2(u[1], u[0]))

    def wall_pose(self, model: ObjectModel, wall: WallPlane, s: float, z: float, lateral: float = 0.0):
        """Pose of ``model`` with its back against ``wall`` at arc length ``s`` (its centre), bottom at z."""
        p0, u, n, _, yaw = self._wall_frame(wall)
        back = -model.bounds[0][1] + self.preset.contact_gap
        xy = p0 + u * s + n * (back + lateral)
        return pose2d(xy[0], xy[1], yaw, z)

    def against_wall(
        self,
        members: list[tuple[ObjectModel, float]],
        corner: bool = False,
        wall_ids: list[int] | None = None,
        tries: int = 40,
    ) -> list[Placed] | None:
        """Place a row of floor objects side by side, backs to one wall: members are (model, gap before it)."""
        widths = [m.size[0] for m, _ in members]
        total = sum(widths) + sum(g for _, g in members[1:])
        walls = list(self.room.walls) if wall_ids is None else [self.room.walls[i] for i in wall_ids]
        for _ in range(tries):
            wall = walls[int(self.rng.integers(len(walls)))]
            _, _, _, length, _ = self._wall_frame(wall)
            if length < total + 0.05:
                continue
            gap = self.preset.contact_gap + 0.002
            if corner:
                start = gap if self.rng.uniform() < 0.5 else length - total - gap
            else:
                start = float(self.rng.uniform(0.1, length - total - 0.1)) if length - total > 0.2 else gap
            poses, s = [], start
            for k, (m, g) in enumerate(members):
                if k:
                    s += g
                poses.append(self.wall_pose(m, wall, s + m.size[0] / 2, 0.0))
                s += m.size[0]
            fps = [footprint(m, p) for (m, _), p in zip(members, poses)]
            if all(self.free(fp, 0.0, m.size[2], self.preset.furniture_clearance) for (m, _), fp in zip(members, fps)):
                return [self._add(m, p, Relation.RESTS_ON, Root.FLOOR, None) for (m, _), p in zip(members, poses)]
        return None

    def in_front(self, anchor: Placed, model: ObjectModel, gap: float, turn: float = np.pi) -> Placed | None:
        """A floor object in front of ``anchor`` (e.g. a chair at a desk), facing it when turn = pi."""
        for _ in range(10):
            lateral = float(self.rng.uniform(-0.2, 0.2)) * anchor.model.size[0]
            dist = anchor.model.bounds[1][1] + gap + model.size[1] / 2
            local = np.array([lateral, dist, 0.0, 1.0])
            world = anchor.world_from_object @ local
            yaw = np.arctan2(anchor.world_from_object[1, 0], anchor.world_from_object[0, 0]) + turn
            yaw += float(self.rng.uniform(-0.25, 0.25))
            offset = -(model.bounds[0] + model.bounds[1]) / 2
            pose = pose2d(world[0], world[1], yaw) @ pose2d(offset[0], offset[1], 0.0)
            fp = footprint(model, pose)
            if self.free(fp, 0.0, model.size[2], 0.02):
                return self._add(model, pose, Relation.RESTS_ON, Root.FLOOR, None)
        return None

    # -- free standing -----------------------------------------------------------------------------------

    def free_standing(self, model: ObjectModel, margin: float = 0.7, tries: int = 60) -> Placed | None:
        region = self.room.polygon.buffer(-margin - max(model.size[:2]) / 2)
        if region.is_empty:
            return None
        x0, y0, x1, y1 = region.bounds
        pr = prep(region)
        from shapely.geometry import Point

        for _ in range(tries):
            x, y = float(self.rng.uniform(x0, x1)), float(self.rng.uniform(y0, y1))
            if not pr.contains(Point(x, y)):
                continue
            yaw = float(self.rng.integers(4)) * np.pi / 2 + float(self.rng.uniform(-0.08, 0.08))
            pose = pose2d(x, y, yaw)
            if self.free(footprint(model, pose), 0.0, model.size[2], 0.5):
                return self._add(model, pose, Relation.RESTS_ON, Root.FLOOR, None)
        return None

    def around(self, table: Placed, chairs: list[ObjectModel]) -> list[Placed]:
        """Chairs around a table, facing it (long sides first)."""
        out = []
        (x0, y0, _), (x1, y1, _) = table.model.bounds
        spots = [(0.0, y1, np.pi), (0.0, y0, 0.0), (x1, 0.0, np.pi / 2), (x0, 0.0, -np.pi / 2)]
        if x1 - x0 > 1.3:
            w = (x1 - x0) / 4
            spots = [(-w, y1, np.pi), (w, y1, np.pi), (-w, y0, 0.0), (w, y0, 0.0)] + spots[2:]
        for chair, (sx, sy, face) in zip(chairs, spots):
            # chair front (+y) faces the table centre; its seat edge sits a few cm off the table edge
            back = chair.size[1] / 2 + 0.08
            nrm = np.array([np.sign(sx) if sy == 0 else 0.0, np.sign(sy) if sy != 0 else 0.0])
            local = np.array([sx + nrm[0] * back, sy + nrm[1] * back, 0.0, 1.0])
            world = table.world_from_object @ local
            table_yaw = np.arctan2(table.world_from_object[1, 0], table.world_from_object[0, 0])
            yaw = table_yaw + face + np.pi + float(self.rng.uniform(-0.15, 0.15))
            off = -(chair.bounds[0] + chair.bounds[1]) / 2
            pose = pose2d(world[0], world[1], yaw) @ pose2d(off[0], off[1], 0.0)
            if self.free(footprint(chair, pose), 0.0, chair.size[2], 0.02):
                out.append(self._add(chair, pose, Relation.RESTS_ON, Root.FLOOR, None))
        return out

    # -- on other objects ---------------------------------------------------------------------------------

    def on(
        self,
        parent: Placed,
        model: ObjectModel,
        facing: bool = False,
        back: bool = False,
        tries: int = 30,
        yaw_jitter: float = 0.2,
    ) -> Placed | None:
        """Rest ``model`` on one of ``parent``'s support surfaces, clear of siblings and everything else."""
        sups = [(k, s) for k, s in enumerate(parent.model.supports) if s.clearance >= model.size[2] + 0.01]
        if not sups:
            return None
        for _ in range(tries):
            k, sup = sups[int(self.rng.integers(len(sups)))]
            yaw = float(self.rng.uniform(-yaw_jitter, yaw_jitter)) if facing else float(self.rng.uniform(-np.pi, np.pi))
            pose_local = self._on_support(model, sup, yaw, back)
            if pose_local is None:
                continue
            fp_local = footprint(model, pose_local)
            siblings = parent.children_on.setdefault(k, [])
            if any(fp_local.buffer(0.01).intersects(o) for o in siblings):
                continue
            pose = parent.world_from_object @ pose_local
            fp = footprint(model, pose)
            z0 = float(pose[2, 3])
            limit = min(parent.top_limit, float(parent.world_from_object[2, 3]) + sup.z + sup.clearance)
            if z0 + model.size[2] > limit - 0.005:
                continue
            ancestors = parent.ancestors | {parent.object_id}
            if not self.free(fp, z0, z0 + model.size[2], 0.005, ignore=ancestors):
                continue
            siblings.append(fp_local)
            return self._add(model, pose, Relation.RESTS_ON, parent.object_id, None, ancestors, limit)
        return None

    def _on_support(self, model: ObjectModel, sup: Support, yaw: float, back: bool):
        rect = box(sup.x0, sup.y0, sup.x1, sup.y1)
        probe = footprint(model, pose2d(0, 0, yaw))
        bx0, by0, bx1, by1 = probe.bounds
        lo_x, hi_x = sup.x0 - bx0, sup.x1 - bx1
        lo_y, hi_y = sup.y0 - by0, sup.y1 - by1
        if lo_x > hi_x or lo_y > hi_y:
            return None
        x = float(self.rng.uniform(lo_x, hi_x))
        y = float(self.rng.uniform(lo_y, lo_y + 0.3 * (hi_y - lo_y))) if back else float(self.rng.uniform(lo_y, hi_y))
        pose = pose2d(x, y, yaw, sup.z + self.preset.contact_gap)
        if not rect.buffer(1e-6).contains(footprint(model, pose)):
            return None
        return pose

    # -- on walls -------------------------------------------------------------------------------------------

    def on_wall(
        self, model: ObjectModel, z_range: tuple[float, float], tries: int = 40, above: Placed | None = None
    ) -> Placed | None:
        """Mount ``model`` on a wall with its back against it and its bottom in ``z_range`` (m)."""
        for _ in range(tries):
            if above is not None:
                # centred above a piece of furniture that stands against a wall (a TV above a cabinet)
                if above.relation != Relation.RESTS_ON or above.parent != Root.FLOOR:
                    return None
                wall = self._wall_behind(above)
                if wall is None:
                    return None
                p0, u, _, _, _ = self._wall_frame(wall)
                s = float((above.world_from_object[:2, 3] - p0) @ u) + float(self.rng.uniform(-0.05, 0.05))
                z = above.z1 + float(self.rng.uniform(*z_range))
            else:
                wall = self.room.walls[int(self.rng.integers(len(self.room.walls)))]
                _, _, _, length, _ = self._wall_frame(wall)
                half = model.size[0] / 2
                if length < 2 * half + 0.3:
                    continue
                s = float(self.rng.uniform(half + 0.15, length - half - 0.15))
                z = float(self.rng.uniform(*z_range))
            if z + model.size[2] > self.room.height - 0.08:
                continue
            pose = self.wall_pose(model, wall, s, z)
            fp = footprint(model, pose)
            if self.free(fp, z, z + model.size[2], 0.12):
                return self._add(model, pose, Relation.MOUNTS_ON, Root.WALL, wall.id)
        return None

    def _wall_behind(self, obj: Placed) -> WallPlane | None:
        back = obj.world_from_object @ np.array([0.0, obj.model.bounds[0][1], 0.0, 1.0])
        best, dist = None, 0.05
        for wall in self.room.walls:
            d = abs(wall.plane.signed_distance(back[None, :3])[0])
            fwd = obj.world_from_object[:2, 1]
            if d < dist and float(fwd @ np.array(wall.plane.normal[:2])) > 0.9:
                best, dist = wall, d
        return best

    def add_door(self) -> None:
        """Keep a door's swing area on one wall free of floor furniture (the door itself is drawn on the wall)."""
        wall = self.room.walls[int(self.rng.integers(len(self.room.walls)))]
        p0, u, n, length, _ = self._wall_frame(wall)
        if length < 1.4:
            return
        s = float(self.rng.uniform(0.5, length - 0.5))
        a, b = p0 + u * (s - 0.45), p0 + u * (s + 0.45)
        self.keepout.append(Polygon([a, b, b + n * 0.9, a + n * 0.9]))
        self.door = (wall.id, s)


def build(name: str, rng: np.random.Generator) -> ObjectModel:
    return CATEGORIES[name](rng)


def furnish(room: Room, preset: SynthPreset, rng: np.random.Generator) -> Layout:
    """Run the preset's placement program; stops at a number of objects drawn from ``preset.objects``."""
    if preset.program == "egocentric":
        from rescene_core.capture.synth.kitchen import furnish_kitchen  # it builds on this module

        return furnish_kitchen(room, preset, rng)
    lay = Layout(room, preset, rng)
    lay.door = None
    lay.add_door()
    target = int(rng.integers(preset.objects[0], preset.objects[1] + 1))

    def full() -> bool:
        return len(lay.objects) >= target

    def step(fn, *args, **kw):
        if full():
            return None
        return fn(*args, **kw)

    if preset.program == "tiny":
        row = step(lay.against_wall, [(build("desk", rng), 0.0)])
        if row:
            step(lay.in_front, row[0], build("chair", rng), 0.12)
            step(lay.on, row[0], build("monitor", rng), facing=True, back=True)
            step(lay.on, row[0], build("book stack", rng))
        step(lay.on_wall, build("picture", rng), (1.2, 1.6))
        step(lay.against_wall, [(build("potted plant", rng), 0.0)], corner=True)
        step(lay.against_wall, [(build("cabinet", rng), 0.0)])
        return lay

    cluttered = preset.program == "cluttered"
    supports: list[Placed] = []
    # big furniture against walls
    if rng.uniform() < 0.85:
        stands = [build("nightstand", rng) for _ in range(2 if rng.uniform() < 0.7 else 1)]
        members = [(stands[0], 0.0), (build("bed", rng), 0.05)] + ([(stands[1], 0.05)] if len(stands) > 1 else [])
        row = step(lay.against_wall, members)
        if row:
            supports += [p for p in row if p.label == "nightstand"]
    row = step(lay.against_wall, [(build("wardrobe", rng), 0.0)], corner=True)
    desk = step(lay.against_wall, [(build("desk", rng), 0.0)])
    if desk:
        step(lay.in_front, desk[0], build("chair", rng), 0.1)
        supports.append(desk[0])
    sofa = step(lay.against_wall, [(build("sofa", rng), 0.0)])
    if sofa:
        lamp = build("floor lamp", rng)
        step(lay.against_wall, [(lamp, 0.0)], corner=True)
    shelves = []
    for _ in range(2 if cluttered else 1):
        r = step(lay.against_wall, [(build("bookshelf", rng), 0.0)], corner=rng.uniform() < 0.5)
        if r:
            shelves.append(r[0])
    cabinets = []
    for _ in range(2 if cluttered else 1):
        r = step(lay.against_wall, [(build("cabinet", rng), 0.0)])
        if r:
            cabinets.append(r[0])
            supports.append(r[0])
    table = step(lay.free_standing, build("dining table", rng))
    if table:
        supports.append(table)
        n_chairs = int(rng.integers(2, 5 if not cluttered else 7))
        if not full():
            lay.around(table, [build("chair", rng) for _ in range(min(n_chairs, target - len(lay.objects)))])
    step(lay.against_wall, [(build("potted plant", rng), 0.0)], corner=True)

    # things on things
    if desk:
        step(lay.on, desk[0], build("monitor", rng), facing=True, back=True)
        step(lay.on, desk[0], build("table lamp", rng))
    for s in supports:
        if s.label == "nightstand":
            step(lay.on, s, build("table lamp", rng))
    stacks: list[Placed] = []
    for s in shelves:
        for _ in range(3 if cluttered else 2):
            placed = step(lay.on, s, build("book stack", rng), facing=True)
            if placed is not None:
                stacks.append(placed)
    if cluttered:
        for host in [p for p in supports if p.label in ("desk", "dining table", "cabinet")]:
            for _ in range(2):
                placed = step(lay.on, host, build("book stack", rng), facing=True)
                if placed is not None:
                    stacks.append(placed)
        for base in list(stacks):
            if rng.uniform() < 0.6 and base.model.supports:
                sup = base.model.supports[0]
                small = book_stack(rng, fit=(sup.x1 - sup.x0, sup.y1 - sup.y0))
                step(lay.on, base, small, facing=True, yaw_jitter=0.05)
    # on walls
    if cabinets and rng.uniform() < 0.7:
        step(lay.on_wall, build("TV", rng), (0.25, 0.45), above=cabinets[0])
    else:
        step(lay.on_wall, build("TV", rng), (0.9, 1.2))
    wall_shelf = step(lay.on_wall, build("wall shelf", rng), (1.15, 1.55))
    for name, zr in (
        ("picture", (1.2, 1.6)),
        ("mirror", (0.6, 0.95)),
        ("wall clock", (1.75, 2.05)),
        ("picture", (1.2, 1.6)),
    ):
        step(lay.on_wall, build(name, rng), zr)
    if wall_shelf:
        step(lay.on, wall_shelf, build("small plant", rng))
        step(lay.on, wall_shelf, build("book stack", rng), facing=True)
    # fill up to the target with small things and pictures
    fillers = ("book stack", "small plant", "picture", "book stack", "table lamp", "picture")
    k = 0
    while not full() and k < 40:
        name = fillers[k % len(fillers)]
        k += 1
        if name == "picture":
            lay.on_wall(build("picture", rng), (1.1, 1.7))
            continue
        hosts = [p for p in lay.objects if p.model.supports and p.label not in ("book stack",)]
        if cluttered and stacks and name == "book stack":
            hosts = hosts + stacks
        if not hosts:
            break
        host = hosts[int(rng.integers(len(hosts)))]
        placed = lay.on(host, build(name, rng), facing=name == "book stack")
        if placed is not None and placed.label == "book stack":
            stacks.append(placed)
    return lay
