"""The room as the attachment rules see it: floor plane, walls with tangent frames, and the floor polygon.

Containment works on the floor polygon (xy, metres). ``fit_translation`` is the one routine that moves a
footprint into a polygon: the smallest translation t with ``footprint + t`` inside, found exactly as the
point of the Minkowski erosion ``polygon ⊖ footprint`` nearest to the origin.

A shell that records which edges of its floor polygon no wall was observed on (``RoomShell.edge_walls``)
has open sides: the floor was not seen to end there. ``Room.polygon``, the region containment keeps objects
in, then reaches ``OPEN_SIDE_REACH`` beyond each open edge (except behind an observed wall), so no repair
pushes an object back across floor that was simply not observed; ``Room.floor_extent`` is the shell's
polygon itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.affinity import translate
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points, unary_union

from rescene_core.assembly.objects import AssemblyError
from rescene_core.records import RoomShell, WallPlane


@dataclass(frozen=True)
class Wall:
    """A wall with its frame. normal: unit [3] into the room; tangent: unit [3] along the segment."""

    id: int
    normal: NDArray[np.float64]
    offset: float
    start: NDArray[np.float64]
    """Segment start (x, y), metres."""
    length: float
    tangent: NDArray[np.float64]

    def distance(self, points: NDArray) -> NDArray[np.float64]:
        """Signed distance (m) of world points [n, 3] to the wall plane, positive inside the room."""
        return np.asarray(points) @ self.normal + self.offset

    def along(self, points: NDArray) -> NDArray[np.float64]:
        """Coordinate (m) along the wall from its segment start of world points [n, 3]."""
        return (np.asarray(points)[:, :2] - self.start) @ self.tangent[:2]


OPEN_SIDE_REACH = 50.0
"""How far (m) beyond an open edge of the floor polygon the containment region reaches: further than any
object stands from the floor seen around it."""


@dataclass(frozen=True)
class Room:
    """Validated room geometry. polygon: the region containment keeps footprints in (the floor polygon,
    reaching across its open edges); None when the shell has no usable floor polygon. floor_extent: the
    shell's floor polygon (None likewise)."""

    shell: RoomShell
    up: NDArray[np.float64]
    floor_offset: float
    walls: tuple[Wall, ...]
    polygon: Polygon | None
    notes: tuple[str, ...]
    floor_extent: Polygon | None = None

    def floor_distance(self, points: NDArray) -> NDArray[np.float64]:
        """Signed distance (m) of world points [n, 3] above the floor plane."""
        return np.asarray(points) @ self.up + self.floor_offset

    def at_height(self, xy: NDArray, height: float) -> NDArray[np.float64]:
        """World points [k, 3] at ``height`` (m) above the floor plane over the (x, y) points ``xy`` [k, 2]."""
        xy = np.asarray(xy, np.float64)
        base = self.floor_distance(np.c_[xy, np.zeros(len(xy))])
        return np.c_[xy, (height - base) / float(self.up[2])]

    def wall(self, wall_id: int) -> Wall | None:
        return next((w for w in self.walls if w.id == wall_id), None)


def _wall(w: WallPlane) -> Wall | None:
    n = np.asarray(w.plane.normal, dtype=np.float64)
    (x0, y0), (x1, y1) = w.segment
    seg = np.array([x1 - x0, y1 - y0], dtype=np.float64)
    length = float(np.linalg.norm(seg))
    if not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-9 or length < 1e-6:
        return None
    scale = np.linalg.norm(n)
    tangent = np.array([seg[0], seg[1], 0.0]) / length
    return Wall(int(w.id), n / scale, float(float(w.plane.offset) / scale), np.array([x0, y0], float), length, tangent)


def open_side_region(polygon: Polygon, shell: RoomShell, walls: tuple[Wall, ...]) -> Polygon:
    """``polygon`` (the shell's floor polygon, valid) grown ``OPEN_SIDE_REACH`` outwards across each edge
    without an observed wall (and the wedge outside a corner between two such edges), none of the growth
    behind an observed wall's segment; ``polygon`` itself when every edge is walled."""
    ring = [np.asarray(p, np.float64) for p in shell.floor_polygon]
    tags = shell.edge_walls
    if tags is None or len(tags) != len(ring) or all(t is not None for t in tags):
        return polygon
    ccw = Polygon(ring).exterior.is_ccw
    across = []
    for k, tag in enumerate(tags):
        a, b = ring[k], ring[(k + 1) % len(ring)]
        d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
        out = np.array([d[1], -d[0]]) if ccw else np.array([-d[1], d[0]])
        if tag is None:
            across.append(Polygon([a, b, b + OPEN_SIDE_REACH * out, a + OPEN_SIDE_REACH * out]))
        prev = ring[k - 1]
        turn = float((a - prev)[0] * d[1] - (a - prev)[1] * d[0]) * (1.0 if ccw else -1.0)
        if tag is None and tags[k - 1] is None and turn > 0:  # the wedge outside a convex corner
            d_in = (a - prev) / max(float(np.linalg.norm(a - prev)), 1e-12)
            across.append(Polygon([a, a + OPEN_SIDE_REACH * d_in, a - OPEN_SIDE_REACH * d]))
    behind = []
    for w in walls:
        start, end = w.start, w.start + w.length * w.tangent[:2]
        back = -OPEN_SIDE_REACH * w.normal[:2]
        behind.append(Polygon([start, end, end + back, start + back]))
    grown = unary_union([g for g in across if g.is_valid and g.area > 0]).difference(unary_union(behind))
    region = unary_union([polygon, grown])
    if not isinstance(region, Polygon):  # the part the floor polygon belongs to
        region = max(getattr(region, "geoms", []), key=lambda g: g.intersection(polygon).area)
    return region


def room_from_shell(shell: RoomShell) -> Room:
    """Check a RoomShell and build the Room. Raises AssemblyError when the floor plane is unusable.

    A shell without walls or without a valid floor polygon is accepted: the rules that need them are
    skipped and say so in ``notes``.
    """
    n = np.asarray(shell.floor.normal, dtype=np.float64)
    if not np.all(np.isfinite(n)) or not np.isfinite(shell.floor.offset) or np.linalg.norm(n) < 1e-9:
        raise AssemblyError(f"room shell floor plane {shell.floor.to_json()} is not finite; re-estimate the shell")
    scale = np.linalg.norm(n)
    up = n / scale
    if up[2] < 0.5:
        raise AssemblyError(f"floor normal {up.tolist()} is not near +z; the world must be z-up")
    notes: list[str] = []
    walls = []
    for w in shell.walls:
        wall = _wall(w)
        if wall is None:
            notes.append(f"wall {w.id} has a degenerate plane or segment; ignored")
        else:
            walls.append(wall)
    if not walls:
        notes.append("room has no usable walls: wall attachment and wall refinements are skipped")
    polygon: Polygon | None = None
    if len(shell.floor_polygon) >= 3:
        poly = Polygon(shell.floor_polygon)
        if not poly.is_valid:
            poly = shapely.make_valid(poly)
            poly = max(getattr(poly, "geoms", [poly]), key=lambda g: g.area)
            notes.append("floor polygon was invalid; its largest valid part is used")
        if isinstance(poly, Polygon) and poly.area > 1e-6:
            polygon = poly
    if polygon is None:
        notes.append("room has no usable floor polygon: containment repairs are skipped")
    region = polygon
    if polygon is not None and shell.open_edges() and Polygon(shell.floor_polygon).is_valid:
        region = open_side_region(polygon, shell, tuple(walls))
        notes.append(
            f"floor polygon edges {list(shell.open_edges())} have no observed wall: containment reaches "
            f"{OPEN_SIDE_REACH} m across them"
        )
    return Room(shell, up, float(float(shell.floor.offset) / scale), tuple(walls), region, tuple(notes), polygon)


def fit_translation(footprint: Polygon, region: Polygon, max_segment: float = 0.05) -> NDArray[np.float64] | None:
    """Smallest (dx, dy) (m) moving ``footprint`` inside ``region``; None when it cannot fit.

    The feasible translations are the intersection of ``region - q`` over points q of the footprint's
    boundary (densified to ``max_segment`` m, so it is exact for convex regions and close otherwise).
    """
    if footprint.within(region):
        return np.zeros(2)
    pts = np.asarray(shapely.segmentize(footprint.exterior, max_segment).coords)[:-1]
    feasible = translate(region, -pts[0, 0], -pts[0, 1])
    for qx, qy in pts[1:]:
        feasible = feasible.intersection(translate(region, -qx, -qy))
        if feasible.is_empty:
            return None
    if feasible.area <= 0:
        return None
    target, _ = nearest_points(feasible, Point(0.0, 0.0))
    return np.array([target.x, target.y])
