"""``rests-on`` object: put the child's contact surface on a feasible support face of its parent.

Support faces are the parent's upward-facing triangles (normal within ``support_normal_deg`` of the floor
normal) grouped into levels of equal height (``support_level_tolerance`` m): a table top, each shelf
board. A level is feasible when its polygon overlaps the child's footprint; among feasible levels the one
nearest in height to the child's lowest point wins (the top level when none overlaps). Closed-form
minimiser: level the child, translate vertically onto the level (at most ``max_support_snap`` m) and
horizontally back over its registered centre (the nearest point of the face when that is off it: a child
registered on its own points is evidence of its own place, not of where its parent's corrections carried
it); an exact shape then moves by the smallest step that puts its whole footprint on the face (its
centroid on the face when the footprint is larger than the face).

A generated parent (``exact_shape`` False) is a single-view completion: a bookshelf comes out as a block or
a slab without its inner boards. A child registered more than ``support_inner_tolerance`` below such a
parent's top stands on an inner face the mesh lacks; unless a level of the mesh lies within that tolerance
of the child's bottom, the rule is skipped and recorded, and the child keeps its registered height rather
than being lifted 1-2 m onto the top (measured on cluttered captures: a dozen book stacks per scene).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Point, Polygon
from shapely.ops import nearest_points

from rescene_core.assembly.evidence import (
    level_pivot,
    levelled_refit,
    levelling,
    points_in_box,
)
from rescene_core.assembly.objects import AssemblyObject, footprint
from rescene_core.assembly.room import Room, fit_translation
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.geometry.sim3 import apply, inverse
from rescene_core.records import Completion, CompletionKind, Edge, InstanceId


@dataclass(frozen=True)
class SupportLevel:
    """One horizontal support face of a parent: height above the floor (m) and its polygon (xy, m)."""

    height: float
    polygon: Polygon


def support_levels_of(
    verts: NDArray, faces: NDArray, room: Room, normal_deg: float, level_tolerance: float
) -> list[SupportLevel]:
    """Upward-facing support levels of a mesh with world vertices [v, 3] and faces [f, 3], highest first."""
    tri = np.asarray(verts)[np.asarray(faces)]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(normals, axis=1)
    ok = area2 > 1e-12
    cos = np.zeros(len(tri))
    cos[ok] = (normals[ok] @ room.up) / area2[ok]
    up_faces = np.flatnonzero(cos >= np.cos(np.radians(normal_deg)))
    if up_faces.size == 0:
        return []
    heights = room.floor_distance(tri[up_faces].mean(axis=1))
    order = np.argsort(-heights)
    levels: list[SupportLevel] = []
    start = 0
    for k in range(1, len(order) + 1):
        if k == len(order) or heights[order[start]] - heights[order[k]] > level_tolerance:
            group = up_faces[order[start:k]]
            polys = shapely.polygons(tri[group][:, :, :2])
            merged = shapely.union_all(shapely.buffer(polys, 1e-6))
            if merged.area > 0:
                hull = merged if isinstance(merged, Polygon) else max(merged.geoms, key=lambda g: g.area)
                levels.append(SupportLevel(float(heights[order[start:k]].max()), hull))
            start = k
    return levels


def support_levels(state: LayoutState, parent: InstanceId) -> list[SupportLevel]:
    """Upward-facing support levels of ``parent`` at its current pose, highest first: its mesh's, and the
    support planes found in its observed points (``board_from_points``)."""
    cfg = state.config
    levels = support_levels_of(
        state.vertices(parent),
        state.objects[parent].faces,
        state.room,
        cfg.support_normal_deg,
        cfg.support_level_tolerance,
    )
    for board in state.completions.get(parent, ()):
        if board.kind is not CompletionKind.SUPPORT_PLANE:
            continue
        world = apply(state.pose(parent), board.points_asset)
        levels.append(SupportLevel(float(state.room.floor_distance(world).mean()), Polygon(world[:, :2])))
    return sorted(levels, key=lambda lv: -lv.height)


BOARD_WINDOW = (0.06, 0.03)
"""A support plane is looked for in the parent's points from this far (m) below to this far above the
child's registered bottom (registration sinks or lifts a child by a few centimetres)."""
BOARD_BIN = 0.02
"""Height bin (m) of the parent's point histogram (about a shelf board's thickness)."""
BOARD_MIN_POINTS = 20
"""Fewest parent points in the peak bin of a support plane."""
BOARD_MIN_RATIO = 1.6
"""The peak bin must hold at least this many times the parent's median bin: a board seen from the front
or from above is a band of points at one height, a side panel spreads its points over every height."""
BOARD_REGION = 0.30
"""Parent points within this distance (m) of the child's footprint are the evidence for its plane."""


def board_from_points(state: LayoutState, parent: InstanceId, child: InstanceId) -> SupportLevel | None:
    """A horizontal support plane of ``parent`` under ``child`` from the parent's observed points (a shelf
    board the capture saw but the generated mesh lacks), at the parent's current pose; None without
    evidence. The plane spans the parent's footprint; it is recorded in ``state.completions`` (asset frame).

    Evidence, at the registered poses: the parent's points inside its registered mesh box (bleed from other
    objects left out) near the child's footprint, binned by height; the fullest bin within ``BOARD_WINDOW``
    of the child's registered bottom must hold ``BOARD_MIN_POINTS`` and ``BOARD_MIN_RATIO`` times the
    median bin. Height: the 75th percentile of the points within one bin of that peak (a board's top, not
    its front edge's middle)."""
    pobj, cobj, room = state.objects[parent], state.objects[child], state.room
    if pobj.points is None or len(pobj.points) == 0:
        return None
    pts = points_in_box(pobj)
    seen = cobj.world_vertices()
    region = footprint(seen).buffer(BOARD_REGION)
    pts = pts[shapely.contains_xy(region, pts[:, 0], pts[:, 1])]
    if len(pts) < BOARD_MIN_POINTS:
        return None
    heights = room.floor_distance(pts)
    bottom = float(room.floor_distance(seen).min())
    edges = np.arange(heights.min(), heights.max() + BOARD_BIN, BOARD_BIN)
    if len(edges) < 3:
        return None
    counts, edges = np.histogram(heights, bins=edges)
    centres = 0.5 * (edges[:-1] + edges[1:])
    window = np.flatnonzero((centres >= bottom - BOARD_WINDOW[0]) & (centres <= bottom + BOARD_WINDOW[1]))
    if window.size == 0:
        return None
    k = int(window[np.argmax(counts[window])])
    typical = float(np.median(counts))  # empty bins count: a parent seen only at its boards has a median of 0
    if counts[k] < BOARD_MIN_POINTS or counts[k] < BOARD_MIN_RATIO * typical:
        return None
    near = heights[np.abs(heights - centres[k]) <= BOARD_BIN]
    height = float(np.clip(np.percentile(near, 75), bottom - BOARD_WINDOW[0], bottom + BOARD_WINDOW[1]))
    return plane_at(
        state, parent, child, height, "the parent's observed points: a shelf board its generated mesh lacks"
    )


def plane_at(
    state: LayoutState, parent: InstanceId, child: InstanceId, height: float, source: str
) -> SupportLevel | None:
    """A support plane of ``parent`` at ``height`` (m above the floor, where the capture saw it) under
    ``child``, spanning the parent's current footprint, recorded as a completion (asset frame); None when
    the room has no usable up direction or the parent has no footprint."""
    room = state.room
    if abs(room.up[2]) < 1e-9:
        return None
    # the height is where the capture saw the board (or the child's bottom): evidence in the world, which a
    # vertical correction of the parent's mesh (a floor snap of a mesh registered 7 cm high) does not move;
    # the plane spans the parent's current footprint (shrunk by 1 cm, so it never reaches beyond the mesh)
    # and is kept in the parent's asset frame, so later repairs carry it with the parent
    now_pose = state.pose(parent)
    now_height = height
    shrunk = footprint(state.vertices(parent)).buffer(-0.01)
    if not isinstance(shrunk, Polygon) or shrunk.is_empty:
        return None
    ring = np.asarray(shrunk.exterior.coords)[:-1]
    world = room.at_height(ring, now_height)
    board = apply(inverse(now_pose), world)
    state.add_completion(Completion(parent, CompletionKind.SUPPORT_PLANE, board, source))
    now = apply(state.pose(parent), board)
    return SupportLevel(float(room.floor_distance(now).mean()), Polygon(now[:, :2]))


MIN_FACE_SHARE = 0.25
"""A generated parent's support level must be at least this share of the child's footprint area: smaller
upward faces are steps of its marching-cubes surface (3 x 3 cm), not faces a child can stand on."""
TOP_TOLERANCE = 0.05
"""... and at most this far (m) above the parent's top (a child registered on a fragmented top)."""
INNER_MIN_ABOVE_BOTTOM = 0.02
"""A child's registered bottom must lie at least this far (m) above its generated parent's mesh bottom to
count as standing on an inner shelf (lower, it stands on the parent's floor board or under it)."""
BOTTOM_BOARD_BELOW = 0.05
"""A child registered lower, down to this far (m) below its generated parent's mesh bottom, stands on the
parent's bottom board (books on a bookshelf's lowest shelf, registered a few centimetres low)."""
INNER_FOOTPRINT_MARGIN = 0.05
"""... and its footprint centre within this distance (m) of the parent's registered footprint."""


def board_at_child(state: LayoutState, parent: InstanceId, child: InstanceId) -> SupportLevel | None:
    """A support plane at the registered bottom of a child that stands inside its generated parent's volume
    when the parent's points show no board there (occluded by what stands on it). The relation says the
    child rests on the parent and the child's points say where it stands; inside a solid single-view
    completion the only surface that can carry it is an inner shelf at that height; the same holds on a
    generated top too fragmented to have a face. None when the child is not inside or on the parent (its
    footprint centre outside the parent's registered footprint, its bottom more than BOTTOM_BOARD_BELOW below
    the parent's bottom or more than TOP_TOLERANCE above its top). A bottom within INNER_MIN_ABOVE_BOTTOM
    of the parent's bottom, or below it, gets the parent's bottom board: a plane at the higher of the two."""
    pobj, cobj, room = state.objects[parent], state.objects[child], state.room
    seen = cobj.world_vertices()
    parent_seen = pobj.world_vertices()
    if not footprint(parent_seen).buffer(INNER_FOOTPRINT_MARGIN).contains(footprint(seen).centroid):
        return None
    bottom = float(room.floor_distance(seen).min())
    parent_heights = room.floor_distance(parent_seen)
    low = float(parent_heights.min())
    if bottom < low - BOTTOM_BOARD_BELOW:
        return None  # under the parent, not on it
    if bottom > float(parent_heights.max()) + TOP_TOLERANCE:
        return None  # above the parent: no plane in mid-air
    if bottom < low + INNER_MIN_ABOVE_BOTTOM:
        return plane_at(state, parent, child, max(bottom, low), "the parent's bottom board under the child")
    return plane_at(
        state, parent, child, bottom, "the child's registered bottom inside its generated parent (an inner shelf)"
    )


EXTENSION_MAX = 0.10
"""Farthest (m) a parent's top is grown to reach a child's registered centre: beyond, a repair moved the
parent on purpose (a snap to its wall), and the child goes with it."""
EXTENSION_SEEN_MARGIN = 0.05
"""The child's registered footprint centre must lie within this distance (m) of the horizontal hull of its
parent's observed points for the parent's face to be extended under it."""


def parent_seen_under(state: LayoutState, parent: InstanceId, child: InstanceId) -> bool:
    """Whether the capture saw ``parent`` under ``child``'s registered place: the child's registered
    footprint centre lies within EXTENSION_SEEN_MARGIN of the horizontal hull of the parent's observed points
    (``evidence.points_in_box``: bleed from other objects left out)."""
    pobj = state.objects[parent]
    if pobj.points is None or len(pobj.points) < BOARD_MIN_POINTS:
        return False
    pts = points_in_box(pobj)
    if len(pts) < BOARD_MIN_POINTS:
        return False
    hull = shapely.MultiPoint(pts[:, :2]).convex_hull
    centre = footprint(state.objects[child].world_vertices()).centroid
    return bool(hull.buffer(EXTENSION_SEEN_MARGIN).contains(centre))


LEVEL_BAND = (0.04, 0.015)
"""Parent points from this far (m) below to this far above a child's registered bottom are its top surface
at the child's level (the child occludes the surface right under it, not the surface around it)."""
LEVEL_REGION = 0.05
"""... when they lie within this distance (m) of the child's registered footprint."""
LEVEL_EXTENSION_MAX = 0.30
"""Farthest (m) a parent's top is grown to reach a child's registered centre when the parent's top surface
was seen around the child (``level_seen_around``): a generated parent that is a slab of its seen front
(a cabinet 4 cm deep against a wall) has its real top behind the child."""


def level_seen_around(state: LayoutState, parent: InstanceId, child: InstanceId) -> float | None:
    """Height (m above the floor) of ``parent``'s surface the capture saw around ``child``'s registered
    footprint at the child's registered bottom (``surface_seen_around``); None without such evidence."""
    return surface_seen_around(state.objects[parent], state.objects[child], state.room)


def surface_seen_around(pobj: AssemblyObject, cobj: AssemblyObject, room: Room) -> float | None:
    """Height (m above the floor) of parent ``pobj``'s surface the capture saw around child ``cobj``'s
    registered footprint at the child's registered bottom: the densest layer (``surface_height``) of the
    heights of the parent's observed points in the ring around the footprint (``ring_around``) within
    LEVEL_BAND of the bottom, when there are at least BOARD_MIN_POINTS of them and their horizontal hull reaches
    within EXTENSION_SEEN_MARGIN of the footprint's centre; else None."""
    return _surface_in_ring(pobj, cobj, room)[0]


def _surface_in_ring(
    pobj: AssemblyObject, cobj: AssemblyObject, room: Room
) -> tuple[float | None, NDArray[np.float64]]:
    """``surface_seen_around`` and the heights (m above the floor) [k] of the parent's observed points in the
    ring around the child's registered footprint, which ``top_seen_around`` compares it with."""
    if pobj.points is None or len(pobj.points) < BOARD_MIN_POINTS:
        return None, np.zeros(0)
    seen = cobj.world_vertices()
    bottom = float(room.floor_distance(seen).min())
    fp = footprint(seen)
    pts = np.asarray(pobj.points, dtype=np.float64)
    pts = pts[shapely.contains_xy(ring_around(fp), pts[:, 0], pts[:, 1])]
    heights = room.floor_distance(pts)
    band = (heights >= bottom - LEVEL_BAND[0]) & (heights <= bottom + LEVEL_BAND[1])
    if int(band.sum()) < BOARD_MIN_POINTS:
        return None, heights
    # the surface must reach the child's centre (EXTENSION_SEEN_MARGIN): a top that ends under the child
    # does not carry it
    hull = shapely.MultiPoint(pts[band][:, :2]).convex_hull
    if not hull.buffer(EXTENSION_SEEN_MARGIN).contains(fp.centroid):
        return None, heights
    return surface_height(heights[band]), heights


def ring_around(fp: Polygon) -> Polygon:
    """Where a parent's points show its surface around a child of footprint ``fp`` (xy, m): within LEVEL_REGION
    of it, not on it. Over the footprint the parent's points are the child's own surface its mask lost to the
    parent (a bowl's side and rim: up to 5 cm above the top it stands on), not the top under it, which the
    child hides. Three bowls generated as discs at their rims on egocentric seeds 0, 2 and 205 had their tops
    read 5.0-5.8 cm high from their own bleed; in the ring alone too few points remain, and no top is read."""
    return fp.buffer(LEVEL_REGION).difference(fp)


def surface_height(heights: NDArray) -> float:
    """Height (m) of the surface seen in ``heights`` [n] (m, n > 0): the median of the densest window of
    2 x SURFACE_HALF_BAND. A flat top fused by voxel means shows as two layers 5-9 mm apart where it straddles
    a voxel boundary: the bulk of a voxel column's depth samples averages to the surface, the noise tail beyond
    the boundary to a layer of its own, which not every column has. Both lie in the window and the bulk layer
    holds most of it, so its median is on the surface; an upper quartile reads the tail's layer (egocentric
    seeds 200-209 and 0-4, the ring's points: 181 children, the band's upper quartile 2.5-8.6 mm above the
    true top for 52; now 8 beyond 2.5 mm, mean error 2.8 -> 0.6 mm)."""
    h = np.sort(np.asarray(heights, dtype=np.float64))
    counts = np.searchsorted(h, h + 2.0 * SURFACE_HALF_BAND, side="right") - np.arange(len(h))
    k = int(np.argmax(counts))
    return float(np.median(h[k : k + int(counts[k])]))


SEEN_TOP_MARGIN = 0.0025
"""A generated parent's face farther than this (m) from the top its observed points show around a child
(``seen_top_around``) is not where the child stands: the seen top carries it (the top read around a child is
within 2.5 mm of the truth for 168 of 176 children on egocentric seeds 200-209 and 0-4; 5 mm while the band's
upper quartile read it, and a counter's face 2.3-2.4 mm above its true top carried three jars and cups)."""
SURFACE_HALF_BAND = 0.01
"""Half the height (m) of the window in which a surface's points are counted (``seen_top_around``)."""
SEEN_TOP_ABOVE = 0.10
"""How far (m) above a surface seen around a child a denser one makes it a front face, not the top (farther
up, a denser layer is a shelf board above the child, not its support's top)."""


def seen_top_around(state: LayoutState, parent: InstanceId, child: InstanceId) -> float | None:
    """Height (m above the floor) at which the capture saw ``parent``'s top around ``child``
    (``level_seen_around``), when that surface is the parent's top there: no window of 2 x SURFACE_HALF_BAND
    higher up (beyond LEVEL_BAND, up to SEEN_TOP_ABOVE) holds more of the parent's observed points in the ring around the
    child's registered footprint than the window at it. Below a dense top the band at a low child's bottom
    holds the parent's front face, not a surface; the child's own bleed above a top is sparse. None without
    such evidence."""
    return top_seen_around(state.objects[parent], state.objects[child], state.room)


def top_seen_around(pobj: AssemblyObject, cobj: AssemblyObject, room: Room) -> float | None:
    """``seen_top_around`` for parent ``pobj`` and child ``cobj`` at their registered poses in ``room``."""
    around, heights = _surface_in_ring(pobj, cobj, room)
    if around is None:
        return None
    heights = np.sort(heights)
    window = np.searchsorted(heights, heights + SURFACE_HALF_BAND, side="right") - np.searchsorted(
        heights, heights - SURFACE_HALF_BAND, side="left"
    )
    at = int(np.count_nonzero(np.abs(heights - around) <= SURFACE_HALF_BAND))
    higher = (heights > around + LEVEL_BAND[1] + SURFACE_HALF_BAND) & (heights <= around + SEEN_TOP_ABOVE)
    above = window[higher]
    return around if above.size == 0 or int(above.max()) <= at else None


def extend_under_child(
    state: LayoutState, parent: InstanceId, child: InstanceId, level: SupportLevel
) -> SupportLevel | None:
    """``level`` of generated ``parent`` grown to carry ``child`` where the child was registered, when the
    registered centre is off the face but the parent was seen under it (``parent_seen_under``): the
    parent's generated top is too small, or a repair moved the parent, not the child, off the evidence. The
    grown face (the convex hull of the face and the child's registered footprint, at the face's height) is a
    ``support plane`` completion in the parent's asset frame, which exporters add as a board; None: no
    evidence, or the centre more than EXTENSION_MAX off the face (LEVEL_EXTENSION_MAX when the parent's top
    was seen around the child, ``level_seen_around``); the child goes to the nearest point of the face."""
    room = state.room
    seen = footprint(state.objects[child].world_vertices())
    reach = level.polygon.distance(seen.centroid)
    if reach > LEVEL_EXTENSION_MAX or abs(room.up[2]) < 1e-9:
        return None
    at_level = level_seen_around(state, parent, child) is not None
    if not at_level and (reach > EXTENSION_MAX or not parent_seen_under(state, parent, child)):
        return None
    grown = shapely.union_all([level.polygon, seen]).convex_hull
    if not isinstance(grown, Polygon) or grown.is_empty:
        return None
    ring = np.asarray(grown.exterior.coords)[:-1]
    world = room.at_height(ring, level.height)
    source = f"the parent's top grown under child {int(child)}, where the capture saw both"
    # one extension per child: a later re-seat replaces the one an earlier stage made
    state.completions[parent] = [c for c in state.completions.get(parent, []) if c.source != source]
    state.add_completion(
        Completion(parent, CompletionKind.SUPPORT_PLANE, apply(inverse(state.pose(parent)), world), source)
    )
    return SupportLevel(level.height, grown)


TOP_FIT_MARGIN = 0.02
"""A generated parent's top farther than this (m) from where its child was registered standing is replaced
by the surface its observed points show there, if any (``board_from_points``)."""


def seen_centre_shift(state: LayoutState, child: InstanceId, moved: NDArray, face: Polygon) -> NDArray[np.float64]:
    """Horizontal step (dx, dy) (m) putting the bounding-box centre of ``moved`` (the child's world vertices
    [v, 3] at its inherited, levelled pose) back over where it was registered, or over the point of the
    support ``face`` nearest to that when the registered centre is not over the face.

    A generated child was registered on its own points, so its registered horizontal position is evidence;
    the move it inherits from its parent's correction (a parent levelled or yawed about its own centre swings
    a child standing near an edge by several centimetres) is not."""
    seen = state.objects[child].world_vertices()
    seen_c = 0.5 * (seen.min(axis=0) + seen.max(axis=0))
    now_c = 0.5 * (moved.min(axis=0) + moved.max(axis=0))
    target = Point(seen_c[0], seen_c[1])
    if not face.contains(target):
        target = nearest_points(face, target)[0]
    return np.array([target.x - now_c[0], target.y - now_c[1]])


def compile_support(
    state: LayoutState, child: InstanceId, edge: Edge
) -> tuple[NDArray[np.float64] | None, dict[str, Any]]:
    """World-frame Sim(3) [4, 4] placing ``child`` on a support face of its parent (None: no face)."""
    cfg, room = state.config, state.room
    parent = InstanceId(int(edge.parent))
    levels = support_levels(state, parent)
    if not levels:
        return None, {"reason": f"parent {parent} has no upward-facing support face"}
    obj = state.objects[child]
    pose = state.pose(child)
    correction, tilt = levelling(state, child, pose, level_pivot(state, child))
    moved = apply(correction @ pose, obj.vertices)
    bottom = float(room.floor_distance(moved).min())
    # the level is chosen by where the child was seen standing, not where its parent's correction took it
    seen_bottom = float(room.floor_distance(obj.world_vertices()).min())
    fp = footprint(moved)
    parent_generated = not state.objects[parent].exact_shape
    if parent_generated:  # a marching-cubes step of a few cm^2 is not a face that can carry anything
        smallest = MIN_FACE_SHARE * fp.area
        levels = [lv for lv in levels if lv.polygon.area >= smallest]
        if not levels:  # a fragmented top: the evidence of a surface under the child, if any
            board = board_from_points(state, parent, child) or board_at_child(state, parent, child)
            if board is None:
                return None, {"reason": f"generated parent {parent} has no support face as large as {smallest:.4f} m^2"}
            levels = [board]
    feasible = [lv for lv in levels if lv.polygon.intersects(fp)]
    board = None
    inner = cfg.support_inner_tolerance
    if parent_generated and inner is not None and seen_bottom < levels[0].height - inner:
        # inside a generated parent: only a level near the child's own height will do (see the docstring)
        feasible = [lv for lv in feasible if abs(lv.height - seen_bottom) <= inner]
        board, evidence = None, ""
        if not feasible:
            board, evidence = board_from_points(state, parent, child), "the parent's observed points"
        if not feasible and board is None:
            board, evidence = board_at_child(state, parent, child), "the child's registered bottom (an inner shelf)"
        if board is not None:
            feasible, levels = [board], sorted([*levels, board], key=lambda lv: -lv.height)
        if not feasible:
            return None, {
                "reason": (
                    f"child stands {levels[0].height - seen_bottom:.2f} m below the top of generated parent "
                    f"{parent}, whose mesh has no support face near its height (an inner shelf it lacks); left "
                    "at its registered pose"
                )
            }
    level = min(feasible, key=lambda lv: abs(lv.height - seen_bottom)) if feasible else levels[0]
    off_by = abs(level.height - seen_bottom)
    if parent_generated and not obj.exact_shape and board is None:
        # the generated face a few millimetres or more from the top the parent's points show around the child
        # (an island's completion 1 cm above its seen worktop, a counter's top lowered with a mesh too short
        # for it): the child stands where the top was seen
        # a child cut where it met that top before the rules (``trim.seat_cuts``) stands on it: estimated again
        # at the cut mesh's bottom, the band above the surface holds the child's own bleed
        top = state.seen_seats.get(child)
        if top is None:
            top = seen_top_around(state, parent, child)
        if top is not None and abs(level.height - top) > SEEN_TOP_MARGIN and abs(top - seen_bottom) < off_by:
            plane = plane_at(state, parent, child, top, "the parent's top seen around the child")
            if plane is not None:
                level, board, evidence = plane, plane, "the parent's observed top around the child"
                off_by = abs(level.height - seen_bottom)
    if parent_generated and not obj.exact_shape and board is None and off_by > TOP_FIT_MARGIN:
        # a generated face too high or too low where the parent's points show the surface the child stands on:
        # at its top, the points in the parent's box; anywhere (a stepped top, a slab of the parent's seen
        # front without points of its top in its box), those around the child at its registered bottom
        seen_board = None
        if level.height >= levels[0].height - cfg.support_level_tolerance:
            seen_board = board_from_points(state, parent, child)
        if seen_board is not None and abs(seen_board.height - seen_bottom) < off_by:
            level, board, evidence = seen_board, seen_board, "the parent's observed points at its top"
        else:
            around = seen_top_around(state, parent, child)
            if around is not None and abs(around - seen_bottom) < off_by:
                plane = plane_at(state, parent, child, around, "the parent's top seen around the child")
                if plane is not None:
                    level, board, evidence = plane, plane, "the parent's observed points around the child"
    lift = float(np.clip(level.height - bottom, -cfg.max_support_snap, cfg.max_support_snap))
    # the child's registered centre is the evidence of where it stands (evidence.py), not where its
    # parent's corrections carried it; an exact shape's whole footprint then goes onto the face
    seen = state.objects[child].world_vertices()
    seen_c = 0.5 * (seen.min(axis=0) + seen.max(axis=0))
    if parent_generated and not obj.exact_shape and not level.polygon.contains(Point(seen_c[0], seen_c[1])):
        grown = extend_under_child(state, parent, child, level)
        if grown is not None:
            level, board, evidence = grown, grown, "the parent's observed points under the child"
    shift: NDArray[np.float64] | None
    shift, how = seen_centre_shift(state, child, moved, level.polygon), "registered centre on face"
    if obj.exact_shape:
        seated = footprint(apply(translation([shift[0], shift[1], 0.0]) @ correction @ pose, obj.vertices))
        onto = fit_translation(seated, level.polygon)
        shift = None if onto is None else shift + onto
        how = "registered centre, footprint on face"
    if shift is None:
        centroid = fp.centroid
        target = centroid if level.polygon.contains(centroid) else nearest_points(level.polygon, centroid)[0]
        shift = np.array([target.x - centroid.x, target.y - centroid.y])
        how = how if not obj.exact_shape else "centroid on face (footprint larger than face)"
    correction = translation([shift[0], shift[1], 0.0] + lift * room.up) @ correction
    # a mesh levelled by a large tilt is not the one registered on the points: its surface goes back onto them
    refit = levelled_refit(state, child, correction @ pose)
    if refit is not None:
        correction = translation(refit) @ correction
        how += ", levelled surface fitted to the points"
    info = {
        "parent": int(parent),
        "level_height_m": level.height,
        "levels": len(levels),
        "tilt_removed_deg": float(np.degrees(tilt)),
        "vertical_m": lift,
        "horizontal_m": shift,
        "placement": how,
    }
    if refit is not None:
        info["refit_m"] = refit
    if board is not None:
        info["support_plane"] = evidence
    return correction, info
