"""Collision pieces the layout adds to an object's decomposition, and the pieces it changes (MJCF and USD).

All pieces here are in the object's body frame: the asset frame scaled by the pose's scale (metres), rotated
and translated by the pose's rotation and translation (rescene_core/export/mjcf.py). Every change is listed
in ``scene/export_report.json`` under the object.

* **Clipping.** A CoACD or hull piece is cut to the mesh's extent along its asset axes, the world's up and
  down and 24 horizontal world directions: a decomposition never reaches past the mesh it approximates in
  those directions. (CoACD's excess on the benchmark scenes lies inside that extent, where a piece fills a
  concavity: the seats below handle the part of it under a child, rescene_core/export/separate.py the part
  where a neighbour stands.)
* **Completions** (``ExportObject.completions``, found by attachment in the object's observed points): a
  ``support plane`` becomes a board ``BOARD_THICKNESS`` thick below the plane
  (``geometry.completion.completion_solid``), a ``base`` the convex hull of its points. Collision only, no
  visual. Attachment builds both within the mesh's footprint; a later cut or correction of the mesh can
  leave one reaching past it (into a neighbour's space), so each is cut to the mesh's horizontal extent.
* **Hollow parents.** A generated parent with a support plane inside its mesh (more than ``INSIDE_MARGIN``
  below its top) and a child (or a child's child) standing in it would push the child out: its solid
  pieces fill the shelf's compartments. Its pieces become a shell of its asset-frame bounding box (bottom,
  top and side panels ``PANEL_THICKNESS`` thick, one vertical side open) plus the boards, cut to the mesh's
  extent like a decomposition (a turned mesh's box reaches past it). The open side: the side opposite the
  one that backs onto a wall (faces it, within ``BACK_WALL_MAX`` of its plane and its segment); when two
  sides back onto walls (a corner) or none does, the free side facing the floor polygon's centre (into the
  room); else (no room) the side nearest the children's centre.
* **Seats.** A child (and its children) stands where its parent's pieces may be: a convex piece fills the
  concavities of the part it covers (CoACD at threshold 0.05 fills dips of centimetres), a hollow shell's
  panels are its mesh's box (a generated shelf 8 cm deep under books 30 cm deep). The parent's pieces are
  carved out of the child's prism: the smallest rotated rectangle around the child's collider, grown by
  ``CARVE_MARGIN``, from the child's bottom to its top (``carve``: each piece split by the prism's side
  planes, the part inside cut at both heights, all convex). Only where the parent's own geometry is not:
  the parent's mesh rises at most ``SEAT_MESH_TOLERANCE`` above the child's bottom inside the prism (moved
  in by ``SEAT_INSET``), or the pieces are a hollow shell, or a support plane of the parent lies within
  ``SUPPORT_MATCH`` of the child's bottom (the layout found an inner shelf there that the mesh lacks). A
  child inside its parent's mesh otherwise is the layout's fault and is left as it is.
* **Boards under a child's foot.** A child standing on a support plane of its parent (within
  ``SUPPORT_MATCH``) whose foot (its points within ``SEAT_FOOT`` of its bottom) reaches past the board gets
  the board extended under the foot: a slab ``BOARD_THICKNESS`` thick under the foot's rectangle, its top
  at the child's bottom. The board spans the generated parent's footprint; the capture saw the child
  standing at that height over its whole foot.
* **Footings.** A free object resting on something stands on its lowest points. A generated mesh's bottom
  is its generator's invention, often uneven: when the centre of mass (of its collision pieces) is not
  over the polygon of its points within ``CONTACT_BAND`` of the lowest one (shrunk by ``FOOTING_MARGIN``),
  it would rock or tip at once (the centre counted with everything resting on it, at their masses: a table
  carries the monitor at its corner). It then gets a footing: the hull of its vertices in the lowest band of its
  height and of the same vertices on the level of its lowest point, with the band grown (``FOOTING_BANDS``
  of the height, up to half of it: a generated lamp's head beside its foot) until the centre is over the
  footing's bottom far enough to resist a tilt of ``FOOTING_TILT_DEG`` (the rotation the physics check
  still calls stable: a centre 14 cm up and 1 cm inside tips at 4 deg), else, when no band does, the first
  band that holds it ``FOOTING_MARGIN`` inside. When no band holds it, nothing is added and the report
  says so.
* **Neighbours** (rescene_core/export/separate.py): pieces of two objects, neither resting on the other,
  that overlap where neither object's mesh or completions are, are cut apart by a plane between the two,
  or, when no plane separates them, the piece filling a concavity the other stands in is carved there;
  when neither works, one piece gives way to the other (convex subtraction).
* **Walls** (rescene_core/export/walls.py): a free object's piece that reaches into the box behind a wall's
  plane by at most ``walls.MAX_DEPTH`` is cut at the plane.

Seats are carved deepest carrier first, so a child's board under its own child is one of its pieces when
its parent carves its seat.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.export.objects import ExportObject
from rescene_core.geometry.completion import completion_solid, hull_mesh
from rescene_core.geometry.sim3 import scale_of
from rescene_core.records import CompletionKind, InstanceId, Relation, RoomShell, SceneGraph

Piece = tuple[NDArray[np.float64], NDArray[np.int64]]

BOARD_THICKNESS = 0.02
"""Thickness (m) of the board a support plane becomes, below the plane."""
PANEL_THICKNESS = 0.02
"""Thickness (m) of a hollow parent's panels (at most a quarter of the box's extent on that axis)."""
INSIDE_MARGIN = 0.05
"""A support plane more than this (m) below the mesh's top is inside the mesh (a shelf, not the top)."""
BACK_WALL_MAX = 0.30
"""A side of a hollow parent within this distance (m) of a wall it faces (within 30 deg), in front of the
wall's segment (up to this far past its ends), backs onto it."""
UPRIGHT_COS = float(np.cos(np.radians(10.0)))
"""A hollow shell needs an asset axis within 10 deg of the world's up."""
SEAT_MESH_TOLERANCE = 0.02
"""A child whose parent's mesh rises more than this (m) above the child's bottom under its foot (the support
contact tolerance of the structural metrics) is inside the mesh: its parent's pieces are not cut."""
SEAT_FOOT = 0.02
"""A child's foot: its points within this height (m) of its lowest one; a board under it covers them."""
SEAT_INSET = 0.01
"""Parent mesh points within this distance (m) inside the edge of a child's footprint do not count as inside
the child (a face touching its side)."""
CARVE_MARGIN = 0.002
"""A child's prism reaches this far (m) past its collider: faces that touch are not left overlapping."""
SUPPORT_MATCH = 0.03
"""A support plane within this distance (m) of a child's bottom is the board the child stands on."""
NEIGHBOUR_CLEARANCE = 0.002
"""A footing or a board under a child's foot reaching this far (m) into a neighbour's geometry reaches into it."""
MIN_PIECE_VOLUME = 1e-8
"""A cut piece smaller than this (m^3, a 1 cm x 1 cm x 0.1 mm sliver) is dropped."""
CONTACT_BAND = 0.001
"""Collider points within this height (m) of the lowest one are the points an object stands on."""
FOOTING_MARGIN = 0.01
"""The centre of mass must be this far (m) inside the polygon an object stands on."""
FOOTING_TILT_DEG = 5.0
"""A footing holds the centre of mass at least (its height above the footing) x tan(this) inside, when a band
can (deg): the rotation the physics check still counts as stable."""
FOOTING_BANDS = (0.02, 0.05, 0.10, 0.15, 0.25, 0.35, 0.5)
"""Heights of the footing's band, as fractions of the object's height (the first that holds is used)."""
CLIP_DIRECTIONS = 24
"""Horizontal world directions (every 15 deg) along which pieces are cut to the mesh's extent."""
FOOTING_MIN_BAND = 0.01
"""Smallest band of a footing (m)."""
WORLD_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Placement:
    """An object's body frame: world = R @ body + t; its mesh in the body frame (metres)."""

    rotation: NDArray[np.float64]
    translation: NDArray[np.float64]
    scale: float
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]

    def world(self, points: NDArray) -> NDArray[np.float64]:
        return np.asarray(points, np.float64) @ self.rotation.T + self.translation

    def body(self, points: NDArray) -> NDArray[np.float64]:
        return (np.asarray(points, np.float64) - self.translation) @ self.rotation


def placement(obj: ExportObject) -> Placement:
    """The body frame of ``obj`` (as rescene_core/export/mjcf.py builds it)."""
    pose = np.asarray(obj.world_from_asset, np.float64)
    scale = scale_of(pose) or 1.0
    u, _, vt = np.linalg.svd(pose[:3, :3] / scale)
    return Placement(
        u @ vt,
        pose[:3, 3].copy(),
        scale,
        np.asarray(obj.vertices, np.float64) * scale,
        np.asarray(obj.faces, np.int64),
    )


@dataclass
class ColliderEdits:
    """What this module did to one object's pieces (the export report's entry)."""

    completions: list[dict[str, Any]] = field(default_factory=list)
    hollow: dict[str, Any] | None = None
    seats: list[dict[str, Any]] = field(default_factory=list)
    boards: list[dict[str, Any]] = field(default_factory=list)
    footing: dict[str, Any] | None = None
    clipped_m: float = 0.0
    separated: list[dict[str, Any]] = field(default_factory=list)
    walls: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "pieces_clipped_to_mesh_m": self.clipped_m,
            "completions": self.completions,
            "hollow_shell": self.hollow,
            "seats_cut": self.seats,
            "boards_under_children": self.boards,
            "footing": self.footing,
            "separated_from_neighbours": self.separated,
            "cut_at_walls": self.walls,
        }


def _hull(points: NDArray) -> Piece | None:
    return hull_mesh(np.asarray(points, np.float64))


def completion_pieces(obj: ExportObject, place: Placement) -> tuple[list[Piece], list[dict[str, Any]]]:
    """Body-frame pieces of ``obj``'s completions and their report entries (a flat or degenerate one is
    reported and left out)."""
    pieces, entries = [], []
    for c in obj.completions:
        if c.kind not in (CompletionKind.SUPPORT_PLANE, CompletionKind.BASE):
            continue  # applied to the mesh itself (a cut), not a collider of its own
        solid = completion_solid(c, obj.world_from_asset, BOARD_THICKNESS)
        hull = _hull(solid * place.scale)
        entry: dict[str, Any] = {
            "kind": c.kind.value,
            "source": c.source,
            "evidence_derived": True,
            "collider": f"board {BOARD_THICKNESS * 100:g} cm thick below the plane"
            if c.kind is CompletionKind.SUPPORT_PLANE
            else "convex hull of the base's points",
        }
        if c.kind is CompletionKind.SUPPORT_PLANE:
            entry["height_m"] = round(float(place.world(np.asarray(c.points_asset) * place.scale)[:, 2].mean()), 4)
        if hull is None:
            entry["collider"] = "none: the solid is flat or degenerate"
        else:
            # both kinds lie under or inside the mesh's footprint (attachment builds them so); a cut or a later
            # correction of the mesh can leave them reaching past it, into a neighbour's space
            clipped, reach = clip_to_mesh(place, [hull], footprint_only=True)
            if reach > 1e-3:
                entry["clipped_to_footprint_m"] = round(reach, 4)
            pieces.append(clipped[0])
        entries.append(entry)
    return pieces, entries


def within_pulled_sides(extra: list[Piece], shell: list[Piece], sides: dict[str, float]) -> list[Piece]:
    """Completion pieces (body frame) of a hollow parent cut at the sides of its shell that were pulled out
    of a wall (``sides``: "+x", "-y", ... as in the report): a base or board must not keep reaching into the
    wall its shell was pulled from. A piece the cut would empty is kept as it was (one piece per entry)."""
    if not shell:
        return extra
    allv = np.vstack([v for v, _ in shell])
    lo, hi = allv.min(axis=0), allv.max(axis=0)
    out = []
    for piece in extra:
        cut: Piece | None = piece
        for side in sides:
            a = "xyz".index(side[1])
            normal, origin = np.zeros(3), np.zeros(3)
            normal[a], origin[a] = (-1.0, hi[a]) if side[0] == "+" else (1.0, lo[a])
            cut = _slice(cut, normal, origin) if cut is not None else None
        out.append(cut if _solid(cut) else piece)  # type: ignore[arg-type]
    return out


def _children(instance: int, graph: SceneGraph | None) -> list[int]:
    """What rests on ``instance`` (sorted ids; none without a graph)."""
    return [] if graph is None else [int(c) for c in graph.children(InstanceId(int(instance)), Relation.RESTS_ON)]


def _depth(instance: int, parent: dict[int, int]) -> int:
    """How many ``rests-on`` object edges (``parent``: ``SceneGraph.object_parents``) lie between ``instance`` and the
    floor or wall (0: it stands on a root); a cycle stops the count."""
    depth, seen = 0, {int(instance)}
    while instance in parent and parent[instance] not in seen:
        instance = parent[instance]
        seen.add(instance)
        depth += 1
    return depth


def _descendants(instance: int, graph: SceneGraph | None) -> list[int]:
    """What rests on it, then on those (breadth first; none without a graph)."""
    return [] if graph is None else [int(c) for c in graph.descendants(InstanceId(int(instance)), Relation.RESTS_ON)]


def hollow_shell(
    obj: ExportObject,
    place: Placement,
    children: list[Placement],
    shell: RoomShell | None,
) -> tuple[list[Piece], dict[str, Any]] | None:
    """The shell pieces replacing a hollow parent's decomposition and the report entry, or None when the
    parent is not hollow (no support plane inside its mesh with a child standing in it)."""
    up = place.rotation.T @ WORLD_UP
    k = int(np.argmax(np.abs(up)))
    world_v = place.world(place.vertices)
    top = float(world_v[:, 2].max())
    heights = []
    for c in obj.completions:
        if c.kind is CompletionKind.SUPPORT_PLANE:
            heights.append(float(place.world(np.asarray(c.points_asset) * place.scale)[:, 2].mean()))
    inner = [h for h in heights if h < top - INSIDE_MARGIN]
    if not inner:
        return None
    lo, hi = place.vertices.min(axis=0), place.vertices.max(axis=0)
    horizontal = [a for a in range(3) if a != k]
    level = hi[k] if up[k] > 0 else -lo[k]
    inside = []
    for child in children:
        cv = place.body(child.world(child.vertices))
        bottom = float(cv[:, k].min() if up[k] > 0 else -cv[:, k].max())
        overlaps = all(cv[:, a].min() < hi[a] and cv[:, a].max() > lo[a] for a in horizontal)
        if overlaps and bottom < level - INSIDE_MARGIN:
            inside.append(cv.mean(axis=0))
    if not inside:
        return None
    if abs(up[k]) < UPRIGHT_COS:
        return None
    sides = [(a, s) for a in range(3) if a != k for s in (-1, 1)]
    centre_b = 0.5 * (lo + hi)

    def face_centre(a: int, s: int) -> NDArray[np.float64]:
        p = centre_b.copy()
        p[a] = hi[a] if s > 0 else lo[a]
        return p

    def normal_world(a: int, s: int) -> NDArray[np.float64]:
        e = np.zeros(3)
        e[a] = s
        return place.rotation @ e

    def face_corners(a: int, s: int) -> NDArray[np.float64]:
        b, c = (x for x in range(3) if x != a)
        corners = np.array([[lo[b], lo[c]], [lo[b], hi[c]], [hi[b], lo[c]], [hi[b], hi[c]]])
        out = np.empty((4, 3))
        out[:, a], out[:, b], out[:, c] = (hi[a] if s > 0 else lo[a]), corners[:, 0], corners[:, 1]
        return place.world(out)

    open_side, reason = None, ""
    backing: set[tuple[int, int]] = set()
    behind: dict[tuple[int, int], float] = {}  # backing side -> how far (m, along its axis) it is behind a wall
    if shell is not None and shell.walls:
        best = None
        for a, s in sides:
            n = normal_world(a, s)
            p = place.world(face_centre(a, s)[None])[0]
            for wall in shell.walls:
                wn = np.asarray(wall.plane.normal, np.float64)
                if float(n @ -wn) < np.cos(np.radians(30.0)):
                    continue
                gap = float(p @ wn + wall.plane.offset)
                (x0, y0), (x1, y1) = wall.segment
                along = np.array([x1 - x0, y1 - y0])
                length = float(np.linalg.norm(along))
                at = float((p[:2] - np.array([x0, y0])) @ along / max(length, 1e-9))
                on_segment = -BACK_WALL_MAX <= at <= length + BACK_WALL_MAX
                if on_segment and -BACK_WALL_MAX < gap < BACK_WALL_MAX:
                    backing.add((a, s))
                    deepest = -float((face_corners(a, s) @ wn + wall.plane.offset).min())
                    if deepest > 0.0:
                        depth = deepest / max(float(n @ -wn), 1e-6)
                        behind[(a, s)] = max(behind.get((a, s), 0.0), depth)
                    if best is None or abs(gap) < abs(best[0]):
                        best = (gap, (a, -s), wall.id)
        if best is not None and len(backing) == 1:
            open_side = best[1]
            reason = f"opposite the side backing onto wall {best[2]} ({best[0]:.3f} m from it)"
    free_sides = [side for side in sides if side not in backing] or sides
    if open_side is None and shell is not None and len(shell.floor_polygon) >= 3:
        room_c = np.asarray(shell.floor_polygon, np.float64).mean(axis=0)
        here = place.world(centre_b[None])[0]
        to_room = np.r_[room_c - here[:2], 0.0]
        if np.linalg.norm(to_room) > 1e-6:
            open_side = max(free_sides, key=lambda side: float(normal_world(*side) @ to_room))
            reason = "the side facing the floor polygon's centre (into the room): " + (
                f"{len(backing)} sides back onto walls (a corner)" if backing else "no wall behind it"
            )
    if open_side is None:
        kids = np.mean(inside, axis=0) - centre_b
        open_side = max(free_sides, key=lambda side: side[1] * kids[side[0]] / max(hi[side[0]] - lo[side[0]], 1e-9))
        reason = "the side nearest the children's centre: no room to face"
    # a side behind the wall it backs onto is pulled back onto the wall's plane (at most a quarter of the
    # box): a panel starting inside a wall is thrown off it at t = 0, with everything standing on the shelf
    pulled = {}
    for (a, side), depth in behind.items():
        cut = min(depth, 0.25 * float(hi[a] - lo[a]))
        if side > 0:
            hi[a] -= cut
        else:
            lo[a] += cut
        pulled[f"{'+' if side > 0 else '-'}{'xyz'[a]}"] = round(cut, 4)
    pieces: list[Piece] = []
    t = np.minimum(PANEL_THICKNESS, 0.25 * (hi - lo))
    for a in range(3):
        for s in (-1, 1):
            if (a, s) == open_side:
                continue
            blo, bhi = lo.copy(), hi.copy()
            if s < 0:
                bhi[a] = lo[a] + t[a]
            else:
                blo[a] = hi[a] - t[a]
            box = trimesh.creation.box(bounds=np.stack([blo, bhi]))
            pieces.append((np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64)))
    pieces, reach = clip_to_mesh(place, pieces)  # a turned mesh's box reaches past the mesh
    axis = "xyz"[open_side[0]]
    entry = {
        "open_side": f"{'+' if open_side[1] > 0 else '-'}{axis} (asset frame)",
        "open_side_world": np.round(normal_world(*open_side), 4).tolist(),
        "reason": reason,
        "panel_thickness_m": round(float(t.min()), 4),
        "inner_support_planes_m": [round(h, 4) for h in inner],
        "children_inside": len(inside),
        "clipped_to_extent_m": round(reach, 4),
        "pulled_out_of_walls_m": pulled,
        "why": "a support plane inside the generated mesh with children standing in it: solid pieces would push "
        "them out",
    }
    return pieces, entry


def _slice(piece: Piece, normal: NDArray, origin: NDArray) -> Piece | None:
    """The part of a convex piece on the side of the plane its normal points to, or None when empty."""
    v, f = piece
    d = (v - origin) @ normal
    if (d >= -1e-9).all():
        return piece
    if (d <= 1e-9).all():
        return None
    mesh = trimesh.Trimesh(v, f, process=False)
    edges = mesh.edges_unique
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    da, db = d[edges[:, 0]], d[edges[:, 1]]
    cross = (da > 0) != (db > 0)
    t = da[cross] / (da[cross] - db[cross])
    points = np.vstack([v[d >= 0], a[cross] + t[:, None] * (b[cross] - a[cross])])
    return _hull(points)


def _ring(points_xy: NDArray, grow: float) -> NDArray[np.float64]:
    """Counter-clockwise corners [4, 2] of the smallest rotated rectangle around ``points_xy``, grown by
    ``grow`` (m) on every side."""
    from shapely.geometry import MultiPoint
    from shapely.geometry.polygon import orient

    rect = MultiPoint(np.asarray(points_xy, np.float64)).minimum_rotated_rectangle
    rect = rect.buffer(max(grow, 1e-4), join_style="mitre")
    return np.asarray(orient(rect, 1.0).exterior.coords, np.float64)[:-1]


def _solid(piece: Piece | None) -> bool:
    return piece is not None and abs(float(trimesh.Trimesh(*piece, process=False).volume)) > MIN_PIECE_VOLUME


UP, DOWN = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])


def carve(pieces: list[Piece], ring: NDArray, z_lo: float, z_hi: float) -> tuple[list[Piece], float]:
    """Pieces (world-oriented frame: z up) with their part inside the vertical prism over the convex polygon
    ``ring`` [k, 2] (counter-clockwise) between heights ``z_lo`` and ``z_hi`` removed. Each piece is split by
    the prism's side planes (the parts outside kept) and the part inside cut at both heights (the parts
    below and above kept): every piece stays convex. Returns the pieces and the largest height (m) removed
    above ``z_lo``."""
    ring = np.asarray(ring, np.float64)
    planes = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        edge = b - a
        length = float(np.hypot(*edge))
        if length > 1e-9:  # outward normal of a counter-clockwise edge
            planes.append((np.array([edge[1], -edge[0], 0.0]) / length, np.array([a[0], a[1], 0.0])))
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    out: list[Piece] = []
    removed = 0.0
    for piece in pieces:
        vlo, vhi = piece[0].min(axis=0), piece[0].max(axis=0)
        if (vlo[:2] >= hi).any() or (vhi[:2] <= lo).any() or vhi[2] <= z_lo or vlo[2] >= z_hi:
            out.append(piece)
            continue
        kept: list[Piece] = []
        rest: Piece | None = piece
        for normal, origin in planes:  # the parts outside the prism, then what is left inside it
            outside = _slice(rest, normal, origin)  # type: ignore[arg-type]
            if _solid(outside):
                kept.append(outside)  # type: ignore[arg-type]
            rest = _slice(rest, -normal, origin)  # type: ignore[arg-type]
            if rest is None:
                break
        low, high = np.array([0.0, 0.0, z_lo]), np.array([0.0, 0.0, z_hi])
        between = None if rest is None else _slice(rest, UP, low)
        if between is not None and np.isfinite(z_hi):
            between = _slice(between, DOWN, high)
        if rest is None or not _solid(between):
            out.append(piece)  # it only touches the prism
            continue
        removed = max(removed, float(between[0][:, 2].max()) - z_lo)  # type: ignore[index]
        for part in (_slice(rest, DOWN, low), _slice(rest, UP, high) if np.isfinite(z_hi) else None):
            if _solid(part):
                kept.append(part)  # type: ignore[arg-type]
        out.extend(kept)
    return out, removed


def cut_seat(pieces: list[Piece], box_lo: NDArray, box_hi: NDArray, level: float) -> tuple[list[Piece], float]:
    """Pieces (world-oriented frame: z up) with everything above ``level`` inside the vertical column over
    the xy box [box_lo, box_hi] removed; returns the pieces and the depth removed (m)."""
    ring = np.array([box_lo, [box_hi[0], box_lo[1]], box_hi, [box_lo[0], box_hi[1]]], np.float64)
    return carve(pieces, ring, level, np.inf)


def _surface_samples(place: Placement) -> NDArray[np.float64]:
    """World points of the mesh's surface: its vertices, face centres and 4000 area-weighted samples."""
    mesh = trimesh.Trimesh(place.world(place.vertices), place.faces, process=False)
    return np.vstack([mesh.vertices, mesh.triangles_center, mesh.sample(4000, seed=0)])


def mesh_overlap(samples: NDArray, mesh: trimesh.Trimesh | None, ring: NDArray, z_lo: float, z_hi: float) -> float:
    """How high (m) a parent's mesh rises above ``z_lo`` inside a child's prism (``ring`` [k, 2], up to
    ``z_hi``, its sides moved in by ``SEAT_INSET``): the highest of its surface ``samples`` there, the whole
    height when the (closed) ``mesh`` contains the prism's centre; 0 when the mesh is not there."""
    import shapely
    from shapely.geometry import Polygon

    inner = Polygon(ring).buffer(-SEAT_INSET, join_style="mitre")
    rise = 0.0
    if not inner.is_empty:
        z = samples[:, 2]
        near = (z > z_lo) & (z <= z_hi)
        sel = near.copy()
        sel[near] = shapely.contains_xy(inner, samples[near, 0], samples[near, 1])
        if sel.any():
            rise = float(z[sel].max()) - z_lo
    if mesh is not None and mesh.is_watertight:
        centre = np.r_[np.asarray(Polygon(ring).centroid.coords)[0], 0.5 * (z_lo + z_hi)]
        if bool(mesh.contains(centre[None])[0]):
            rise = max(rise, z_hi - z_lo)
    return rise


@dataclass(frozen=True)
class Seated:
    """A child (or a child's child) to seat in its parent's pieces: its node, its placement and its collider
    pieces (body frame); ``direct``: it rests on the parent itself (not on one of the parent's children)."""

    node: str
    place: Placement
    pieces: list[Piece]
    direct: bool


def seat_children(
    parent: Placement,
    pieces: list[Piece],
    children: Iterable[Seated],
    supports: Iterable[tuple[float, NDArray]] = (),
    hollow: bool = False,
    others: NDArray | None = None,
) -> tuple[list[Piece], list[dict[str, Any]], list[dict[str, Any]]]:
    """``parent``'s body-frame pieces carved where its children stand, and boards under their feet (see the
    module doc); returns the pieces, the seat entries and the board entries of the export report.
    ``supports``: the parent's support-plane boards, (world height m, world xy of the board's corners [k, 2]);
    ``hollow``: its pieces are a shell (``hollow_shell``); ``others``: world points [n, 3] of the geometry of
    neighbours (not its children), which a board under a child's foot must not reach into."""
    from shapely.geometry import MultiPoint, Polygon

    boards_xy = [(h, MultiPoint(np.asarray(xy, np.float64)).convex_hull.buffer(1e-3)) for h, xy in supports]
    entries, boards = [], []
    off = parent.translation
    work: list[Piece] = [((parent.rotation @ v.T).T, f) for v, f in pieces]  # world-oriented, origin at the body
    samples, mesh = None, None
    for child in children:
        cw = np.vstack([child.place.world(child.place.vertices)] + [child.place.world(v) for v, _ in child.pieces])
        bottom, top = float(cw[:, 2].min()), float(cw[:, 2].max())
        ring = _ring(cw[:, :2], CARVE_MARGIN)
        local = ring - off[:2]
        carved, depth = carve(work, local, bottom - off[2], top + CARVE_MARGIN - off[2])
        board = next((b for b in boards_xy if abs(b[0] - bottom) <= SUPPORT_MATCH), None) if child.direct else None
        if depth > 1e-4:
            if samples is None:
                samples = _surface_samples(parent)
                mesh = trimesh.Trimesh(parent.world(parent.vertices), parent.faces, process=True)
            rise = mesh_overlap(samples, mesh, ring, bottom, top)
            entry: dict[str, Any] = {"child": child.node, "depth_m": round(depth, 4), "mesh_overlap_m": round(rise, 4)}
            if rise <= SEAT_MESH_TOLERANCE:
                why = "the parent's convex pieces filled a concavity of its mesh where the child stands"
            elif hollow:
                why = "the hollow shell's panels (its mesh's box) run through the child, which the capture saw there"
            elif board is not None:
                why = (
                    f"the child stands on the parent's support plane at {board[0]:.3f} m inside its generated mesh "
                    "(an inner shelf the mesh lacks)"
                )
            else:
                why = (
                    f"the parent's mesh reaches {rise:.3f} m above the child's bottom inside the child: the child "
                    "is inside the mesh (a layout fault), left as it is"
                )
                entries.append({**entry, "cut": False, "why": why})
                continue
            work = carved
            entries.append({**entry, "cut": True, "why": why})
        foot = cw[cw[:, 2] <= bottom + SEAT_FOOT]
        fring = _ring(foot[:, :2], 0.0)
        if board is not None and not Polygon(fring).within(board[1]):  # the foot reaches past the board
            fring = fring - off[:2]
            level = bottom - off[2]
            slab = np.vstack(
                [np.c_[fring, np.full(len(fring), level)], np.c_[fring, np.full(len(fring), level - BOARD_THICKNESS)]]
            )
            piece = _hull(slab)
            if piece is not None and others is not None and len(others):
                if inside_piece(others, (piece[0] + off, piece[1])).any():
                    piece = None  # a neighbour stands there: the board is not the child's alone
            if piece is not None:
                work.append(piece)
                boards.append(
                    {
                        "child": child.node,
                        "height_m": round(bottom, 4),
                        "support_plane_m": round(board[0], 4),
                        "why": "the child was seen standing on the parent's support plane here: the board, "
                        f"{BOARD_THICKNESS * 100:g} cm thick, reaches under its foot",
                    }
                )
    return [((parent.rotation.T @ v.T).T, f) for v, f in work], entries, boards


def clip_to_mesh(place: Placement, pieces: list[Piece], footprint_only: bool = False) -> tuple[list[Piece], float]:
    """Pieces cut to the mesh's extent along the asset axes, the world's up and down and ``CLIP_DIRECTIONS``
    horizontal world directions (a discrete oriented polytope of the mesh): a decomposition's piece never
    reaches past the mesh it approximates in those directions. ``footprint_only``: along the horizontal
    world directions only (a completion under or inside the mesh's footprint). Returns the pieces and the
    largest distance (m) a piece reached past them."""
    angles = np.arange(CLIP_DIRECTIONS) * 2 * np.pi / CLIP_DIRECTIONS
    horizontal = np.c_[np.cos(angles), np.sin(angles), np.zeros_like(angles)]
    if footprint_only:
        dirs = horizontal @ place.rotation  # body frame
    else:
        world_dirs = np.vstack([horizontal, [[0, 0, 1.0], [0, 0, -1.0]]])
        dirs = np.vstack([np.eye(3), -np.eye(3), world_dirs @ place.rotation])
    reach_of = place.vertices @ dirs.T
    far = place.vertices[np.argmax(reach_of, axis=0)]
    planes = [(-n, p) for n, p in zip(dirs, far, strict=True)]  # keep n . x <= n . p
    out, reach = [], 0.0
    for piece in pieces:
        v = piece[0]
        for normal, origin in planes:
            reach = max(reach, float(-((v - origin) @ normal).min()))
        rest: Piece | None = piece
        for normal, origin in planes:
            if rest is None:
                break
            rest = _slice(rest, normal, origin)
        if rest is not None:
            out.append(rest)
    return (out, reach) if out else (list(pieces), 0.0)


def inside_piece(points: NDArray, piece: Piece, tolerance: float = -NEIGHBOUR_CLEARANCE) -> NDArray[np.bool_]:
    """Which ``points`` [n, 3] lie inside the convex ``piece`` (same frame), its faces moved out by
    ``tolerance`` (m; negative: in)."""
    normals, offsets = face_planes(piece)
    return ((np.asarray(points, np.float64) @ normals.T - offsets) <= tolerance).all(axis=1)


def face_planes(piece: Piece) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Outward unit normals [f, 3] and offsets [f] (n . x = offset) of a convex piece's faces; degenerate
    (zero-area) faces left out."""
    mesh = trimesh.Trimesh(*piece, process=False)
    keep = np.linalg.norm(mesh.face_normals, axis=1) > 0.5
    normals = mesh.face_normals[keep]
    return normals, np.einsum("ij,ij->i", normals, mesh.triangles[keep, 0])


def centre_of_mass(pieces: list[Piece]) -> NDArray[np.float64] | None:
    vols, centres = [], []
    for v, f in pieces:
        mesh = trimesh.Trimesh(v, f, process=False)
        vol = abs(float(mesh.volume))
        if vol > 1e-12:
            vols.append(vol)
            centres.append(mesh.center_mass)
    if not vols:
        return None
    return np.average(np.asarray(centres), axis=0, weights=vols)


def _support_margin(points_xy: NDArray, centre_xy: NDArray) -> float:
    """Signed distance (m) of ``centre_xy`` inside the convex hull of ``points_xy`` (negative: outside)."""
    from shapely.geometry import MultiPoint, Point

    hull = MultiPoint(points_xy).convex_hull
    if hull.geom_type != "Polygon":
        return -float(hull.distance(Point(centre_xy))) - 1e-9
    p = Point(centre_xy)
    return float(hull.exterior.distance(p)) if hull.contains(p) else -float(hull.exterior.distance(p))


def footing(
    place: Placement,
    pieces: list[Piece],
    mass: float = 1.0,
    load: Iterable[tuple[float, NDArray]] = (),
    others: NDArray | None = None,
) -> tuple[Piece | None, dict[str, Any] | None]:
    """A footing piece (body frame) for an object that would rock on its lowest points, and its report
    entry; (None, None) when it stands as it is. ``load``: (mass kg, world centre of mass) of what rests
    on the object (its children, theirs, ...), whose weight it carries; ``mass``: its own (kg). ``others``:
    world points [n, 3] of neighbours' geometry (meshes, completions), which a footing must not reach into
    (a band that would is skipped)."""
    com = centre_of_mass(pieces)
    if com is None:
        return None, None
    masses, centres = [mass], [place.world(com[None])[0]]
    for m, c in load:
        masses.append(m)
        centres.append(np.asarray(c, np.float64))
    com_w = np.average(np.asarray(centres), axis=0, weights=np.asarray(masses))
    cw = place.world(np.vstack([v for v, _ in pieces]))
    zmin = float(cw[:, 2].min())
    margin = _support_margin(cw[cw[:, 2] <= zmin + CONTACT_BAND, :2], com_w[:2])
    if margin >= FOOTING_MARGIN:
        return None, None
    mesh_w = place.world(place.vertices)
    height = float(mesh_w[:, 2].max() - zmin)
    tilt_margin = max(FOOTING_MARGIN, float(com_w[2] - zmin) * np.tan(np.radians(FOOTING_TILT_DEG)))
    blocked = False
    holding: list[tuple[Piece, dict[str, Any]]] = []  # bands holding the centre FOOTING_MARGIN inside
    for frac in FOOTING_BANDS:
        band = max(FOOTING_MIN_BAND, frac * height)
        low = mesh_w[mesh_w[:, 2] <= zmin + band]
        if len(low) < 3:
            continue
        held = _support_margin(low[:, :2], com_w[:2])
        if held < FOOTING_MARGIN:
            continue
        flat = low.copy()
        flat[:, 2] = zmin
        piece = _hull(place.body(np.vstack([low, flat])))
        if piece is None:
            continue
        if others is not None and len(others) and inside_piece(others, (place.world(piece[0]), piece[1])).any():
            blocked = True
            continue
        entry = {
            "band_m": round(band, 4),
            "band_fraction_of_height": frac,
            "support_margin_before_m": round(margin, 4),
            "support_margin_after_m": round(held, 4),
            "tilt_margin_m": round(float(tilt_margin), 4),
            "why": "its centre of mass (with what rests on it) is not over the points it stands on (an uneven "
            "generated bottom): the hull of its lowest band, down to its lowest point, is added",
        }
        if held >= tilt_margin:
            return piece, entry
        holding.append((piece, entry))
    if holding:  # none resists the tilt: the first that holds the centre at all
        return holding[0]
    return None, {
        "band_m": None,
        "support_margin_before_m": round(margin, 4),
        "why": f"none added: no band up to {FOOTING_BANDS[-1]:g} of its height holds its centre of mass"
        + (" without reaching into a neighbour" if blocked else ""),
    }


def edit_colliders(
    objects: list[ExportObject],
    pieces: dict[str, list[Piece]],
    hollow: dict[str, tuple[list[Piece], dict[str, Any]]],
    graph: SceneGraph | None,
    kinds: dict[str, str],
    methods: dict[str, str],
    masses: dict[str, float] | None = None,
    shell: RoomShell | None = None,
) -> dict[str, ColliderEdits]:
    """Apply the edits of the module doc to ``pieces`` (node -> body-frame decomposition pieces, changed in
    place): clipping to the mesh (CoACD and hull pieces; ``methods``: node -> decomposition method), hollow
    shells (computed by ``find_hollow``), completions, seats, footings, free bodies' pieces cut at the walls
    of ``shell`` they graze (rescene_core/export/walls.py), neighbours cut apart, in that order.
    ``masses``: node -> kg, for the load a footing carries (1 kg each when not given)."""
    places = {o.node_name: placement(o) for o in objects}
    by_instance = {int(o.instance): o for o in objects}
    edits = {o.node_name: ColliderEdits() for o in objects}
    added: dict[str, list[Piece]] = {}
    for obj in objects:
        name = obj.node_name
        if name in hollow:  # cut to its extent already
            pieces[name], reach = list(hollow[name][0]), 0.0
            edits[name].hollow = hollow[name][1]
        elif methods.get(name) not in ("components", "shell"):
            pieces[name], reach = clip_to_mesh(places[name], pieces[name])
        else:
            reach = 0.0
        if reach > 1e-4:
            edits[name].clipped_m = round(reach, 4)
        extra, entries = completion_pieces(obj, places[name])
        if name in hollow and hollow[name][1].get("pulled_out_of_walls_m"):
            extra = within_pulled_sides(extra, pieces[name], hollow[name][1]["pulled_out_of_walls_m"])
        added[name] = extra
        pieces[name] = list(pieces[name]) + extra
        edits[name].completions = entries
    from rescene_core.export.separate import evidence_points, separate

    evidence = {o.node_name: evidence_points(places[o.node_name], added[o.node_name]) for o in objects}
    related = {
        frozenset((o.node_name, by_instance[d].node_name))
        for o in objects
        for d in _descendants(o.instance, graph)
        if d in by_instance
    }
    boxes = {n: (np.vstack(e).min(axis=0), np.vstack(e).max(axis=0)) for n, e in evidence.items()}

    def others_of(name: str) -> NDArray[np.float64]:
        """World points of the geometry of the objects near ``name`` that neither rest on it nor carry it."""
        lo, hi = boxes[name][0] - 0.5, boxes[name][1] + 0.5
        near = [
            np.vstack(evidence[n])
            for n in evidence
            if n != name
            and frozenset((n, name)) not in related
            and (boxes[n][0] <= hi).all()
            and (boxes[n][1] >= lo).all()
        ]
        return np.vstack(near) if near else np.zeros((0, 3))

    # the deepest carriers first: a book stack's board under the box it carries is one of its pieces before
    # the shelf it stands in carves the stack's seat (else the shelf's side keeps the part under that board)
    parent_object = {int(c): int(p) for c, p in (graph.object_parents(Relation.RESTS_ON) if graph else {}).items()}
    for obj in sorted(objects, key=lambda o: -_depth(int(o.instance), parent_object)):
        name = obj.node_name
        seated, todo, seen = [], [(c, True) for c in _children(obj.instance, graph)], {int(obj.instance)}
        while todo:  # its children, then theirs: a stack on a book inside a shelf stands in the shelf too
            c, direct = todo.pop(0)
            if c in seen or c not in by_instance:
                continue
            seen.add(c)
            node = by_instance[c].node_name
            seated.append(Seated(node, places[node], pieces[node], direct))
            todo += [(g, False) for g in _children(c, graph)]
        if not seated:
            continue
        made = [e for e in edits[name].completions if not e["collider"].startswith("none")]
        supports = [
            (e["height_m"], places[name].world(v)[:, :2])
            for e, (v, _) in zip(made, added[name], strict=True)
            if e["kind"] == CompletionKind.SUPPORT_PLANE.value
        ]
        pieces[name], edits[name].seats, edits[name].boards = seat_children(
            places[name], pieces[name], seated, supports, name in hollow, others_of(name)
        )
    parents = graph.parent_of() if graph is not None else {}
    masses = masses or {}
    centres = {}
    for name, ps in pieces.items():
        com = centre_of_mass(ps)
        if com is not None:
            centres[name] = places[name].world(com[None])[0]

    def carried(instance: int, seen: frozenset[int]) -> list[tuple[float, NDArray]]:
        out = []
        for c in _children(instance, graph):
            if c in by_instance and c not in seen and by_instance[c].node_name in centres:
                node = by_instance[c].node_name
                out.append((masses.get(node, 1.0), centres[node]))
                out += carried(c, seen | {c})
        return out

    for obj in objects:
        name = obj.node_name
        edge = parents.get(obj.instance)
        if kinds.get(name) != "free" or edge is None or edge.relation != Relation.RESTS_ON:
            continue
        load = carried(int(obj.instance), frozenset({int(obj.instance)}))
        piece, entry = footing(places[name], pieces[name], masses.get(name, 1.0), load, others_of(name))
        if entry is not None and load:
            entry["load_kg"] = round(sum(m for m, _ in load), 3)
        if piece is not None:
            pieces[name].append(piece)
        edits[name].footing = entry
    from rescene_core.export.walls import clear_of_walls, trimmed_walls, walls_report

    walls = trimmed_walls(shell)
    for name in pieces:
        if kinds.get(name) == "free":
            pieces[name], cut = clear_of_walls(places[name], pieces[name], walls)
            edits[name].walls = walls_report(cut)
    for name, rows in separate(places, pieces, evidence, related, added).items():
        edits[name].separated = rows
    return edits


def find_hollow(
    objects: list[ExportObject], graph: SceneGraph | None, shell: RoomShell | None
) -> dict[str, tuple[list[Piece], dict[str, Any]]]:
    """Node -> (shell pieces, report entry) of every hollow parent (see ``hollow_shell``)."""
    by_instance = {int(o.instance): o for o in objects}
    out = {}
    for obj in objects:
        if not any(c.kind is CompletionKind.SUPPORT_PLANE for c in obj.completions):
            continue
        kids = [placement(by_instance[c]) for c in _descendants(obj.instance, graph) if c in by_instance]
        found = hollow_shell(obj, placement(obj), kids, shell)
        if found is not None:
            out[obj.node_name] = found
    return out
