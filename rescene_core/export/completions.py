"""Collision pieces the layout adds to an object's decomposition, and the pieces it changes (MJCF and USD).

All pieces here are in the object's body frame: the asset frame scaled by the pose's scale (metres), rotated
and translated by the pose's rotation and translation (rescene_core/export/mjcf.py). Every change is listed
in ``scene/export_report.json`` under the object.

* **Clipping.** A CoACD or hull piece is cut to the mesh's extent along its asset axes, the world's up and
  down and 24 horizontal world directions: a decomposition never reaches past the mesh it approximates in
  those directions. (CoACD's excess on the benchmark scenes lies inside that extent, where a piece fills a
  concavity: the seats below handle the part of it that matters, under a child.)
* **Completions** (``ExportObject.completions``, found by attachment in the object's observed points): a
  ``support plane`` becomes a board ``BOARD_THICKNESS`` thick below the plane
  (``geometry.completion.completion_solid``), a ``base`` the convex hull of its points. Collision only, no
  visual.
* **Hollow parents.** A generated parent with a support plane inside its mesh (more than ``INSIDE_MARGIN``
  below its top) and a child standing in it would push the child out: its solid pieces fill the shelf's
  compartments. Its pieces become a shell of its asset-frame bounding box (bottom, top and side panels
  ``PANEL_THICKNESS`` thick, one vertical side open) plus the boards. The open side: the side opposite the
  one that backs onto a wall (faces it, within ``BACK_WALL_MAX`` of its plane and its segment), else the
  side facing the floor polygon's centre (into the room), else (no room) the side nearest the children's
  centre. A hollow parent's seats are not cut: its boards are at its children's feet already.
* **Seats.** A convex piece fills the concavities of the part it covers (CoACD at threshold 0.05 fills
  dips of centimetres), so a child the layout put on its parent's mesh can start inside its parent's
  pieces. When the child's bottom is on the mesh (the parent's mesh rises less than ``SEAT_MESH_TOLERANCE``
  above it under the child's foot, its vertices within ``SEAT_FOOT`` of its lowest), the parent's pieces
  are cut down to the child's bottom over the foot's box: each piece is split by the box's four vertical planes and the part inside is cut at the
  child's bottom (all convex). A child inside its parent's mesh is the layout's fault and is left as it is.
* **Footings.** A free object resting on something stands on its lowest points. A generated mesh's bottom
  is its generator's invention, often uneven: when the centre of mass (of its collision pieces) is not
  over the polygon of its points within ``CONTACT_BAND`` of the lowest one (shrunk by ``FOOTING_MARGIN``),
  it would rock or tip at once (the centre counted with everything resting on it, at their masses: a table
  carries the monitor at its corner). It then gets a footing: the hull of its vertices in the lowest band of its
  height and of the same vertices on the level of its lowest point, with the band grown (``FOOTING_BANDS``
  of the height) until the centre is over the footing's bottom. When no band holds it, nothing is added
  and the report says so.
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
from rescene_core.records import CompletionKind, Relation, RoomShell, Root, SceneGraph

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
"""A child's foot: its vertices within this height (m) of its lowest one; the seat is cut under them."""
CONTACT_BAND = 0.001
"""Collider points within this height (m) of the lowest one are the points an object stands on."""
FOOTING_MARGIN = 0.01
"""The centre of mass must be this far (m) inside the polygon an object stands on."""
FOOTING_BANDS = (0.02, 0.05, 0.10, 0.15, 0.25)
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
    footing: dict[str, Any] | None = None
    clipped_m: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "pieces_clipped_to_mesh_m": self.clipped_m,
            "completions": self.completions,
            "hollow_shell": self.hollow,
            "seats_cut": self.seats,
            "footing": self.footing,
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
            pieces.append(hull)
        entries.append(entry)
    return pieces, entries


def _children(instance: int, graph: SceneGraph | None) -> list[int]:
    if graph is None:
        return []
    return sorted(
        int(e.child)
        for e in graph.edges
        if e.relation == Relation.RESTS_ON and not isinstance(e.parent, Root) and int(e.parent) == int(instance)
    )


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
    inside = []
    for child in children:
        cv = place.body(child.world(child.vertices))
        bottom = float(cv[:, k].min() if up[k] > 0 else -cv[:, k].max())
        centre = cv.mean(axis=0)
        level = hi[k] if up[k] > 0 else -lo[k]
        horizontal = [a for a in range(3) if a != k]
        within = all(lo[a] <= centre[a] <= hi[a] for a in horizontal)
        if within and bottom < level - INSIDE_MARGIN:
            inside.append(centre)
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

    open_side, reason = None, ""
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
                if on_segment and -BACK_WALL_MAX < gap < BACK_WALL_MAX and (best is None or abs(gap) < abs(best[0])):
                    best = (gap, (a, -s), wall.id)
        if best is not None:
            open_side = best[1]
            reason = f"opposite the side backing onto wall {best[2]} ({best[0]:.3f} m from it)"
    if open_side is None and shell is not None and len(shell.floor_polygon) >= 3:
        room_c = np.asarray(shell.floor_polygon, np.float64).mean(axis=0)
        here = place.world(centre_b[None])[0]
        to_room = np.r_[room_c - here[:2], 0.0]
        if np.linalg.norm(to_room) > 1e-6:
            open_side = max(sides, key=lambda side: float(normal_world(*side) @ to_room))
            reason = "the side facing the floor polygon's centre (into the room): no wall behind it"
    if open_side is None:
        kids = np.mean(inside, axis=0) - centre_b
        open_side = max(sides, key=lambda side: side[1] * kids[side[0]] / max(hi[side[0]] - lo[side[0]], 1e-9))
        reason = "the side nearest the children's centre: no room to face"
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
    axis = "xyz"[open_side[0]]
    entry = {
        "open_side": f"{'+' if open_side[1] > 0 else '-'}{axis} (asset frame)",
        "open_side_world": np.round(normal_world(*open_side), 4).tolist(),
        "reason": reason,
        "panel_thickness_m": round(float(t.min()), 4),
        "inner_support_planes_m": [round(h, 4) for h in inner],
        "children_inside": len(inside),
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


def cut_seat(pieces: list[Piece], box_lo: NDArray, box_hi: NDArray, level: float) -> tuple[list[Piece], float]:
    """Pieces (world-oriented frame: z up) with everything above ``level`` inside the vertical column over
    the xy box [box_lo, box_hi] removed; returns the pieces and the depth removed (m)."""
    out: list[Piece] = []
    removed = 0.0
    planes = [
        (np.array([-1.0, 0, 0]), np.array([box_lo[0], 0, 0])),
        (np.array([1.0, 0, 0]), np.array([box_hi[0], 0, 0])),
        (np.array([0, -1.0, 0]), np.array([0, box_lo[1], 0])),
        (np.array([0, 1.0, 0]), np.array([0, box_hi[1], 0])),
    ]
    for piece in pieces:
        v = piece[0]
        over = (v[:, 0].min() < box_hi[0]) and (v[:, 0].max() > box_lo[0])
        over = over and (v[:, 1].min() < box_hi[1]) and (v[:, 1].max() > box_lo[1]) and v[:, 2].max() > level
        if not over:
            out.append(piece)
            continue
        rest: Piece | None = piece
        for normal, origin in planes:  # the parts outside the column, then what is left inside it
            if rest is None:
                break
            outside = _slice(rest, normal, origin)
            if outside is not None:
                out.append(outside)
            rest = _slice(rest, -normal, origin)
        if rest is not None:
            removed = max(removed, float(rest[0][:, 2].max()) - level)
            below = _slice(rest, np.array([0, 0, -1.0]), np.array([0, 0, level]))
            if below is not None:
                out.append(below)
    return out, removed


def _mesh_top_under(place: Placement, lo: NDArray, hi: NDArray) -> float:
    """Highest world z of the mesh's surface over the xy box [lo, hi] (vertices and face centres sampled)."""
    mesh = trimesh.Trimesh(place.world(place.vertices), place.faces, process=False)
    pts = np.vstack([mesh.vertices, mesh.triangles_center, mesh.sample(4000, seed=0)])
    inside = (pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0]) & (pts[:, 1] >= lo[1]) & (pts[:, 1] <= hi[1])
    return float(pts[inside, 2].max()) if inside.any() else -np.inf


def seat_children(
    parent: Placement, pieces: list[Piece], children: Iterable[tuple[str, Placement]]
) -> tuple[list[Piece], list[dict[str, Any]]]:
    """``parent``'s body-frame pieces cut down under each child that starts inside them (see module doc)."""
    entries = []
    level_frame = [(parent.rotation @ v.T).T for v, _ in pieces]  # world-oriented, origin at the body
    work: list[Piece] = [(lv, f) for lv, (_, f) in zip(level_frame, pieces, strict=True)]
    for node, child in children:
        cw = child.world(child.vertices)
        bottom = float(cw[:, 2].min())
        foot = cw[cw[:, 2] <= bottom + SEAT_FOOT]
        lo, hi = foot[:, :2].min(axis=0), foot[:, :2].max(axis=0)
        off = parent.translation
        top = max((float(v[:, 2].max()) + off[2] for v, _ in work), default=-np.inf)
        if top <= bottom + 1e-4:
            continue
        mesh_top = _mesh_top_under(parent, lo, hi)
        if mesh_top > bottom + SEAT_MESH_TOLERANCE:
            entries.append(
                {
                    "child": node,
                    "cut": False,
                    "why": f"the parent's mesh rises {mesh_top - bottom:.3f} m above the child's bottom: the "
                    "child is inside the mesh (a layout fault), left as it is",
                }
            )
            continue
        work, removed = cut_seat(work, lo - off[:2], hi - off[:2], bottom - off[2])
        if removed > 1e-4:
            entries.append(
                {
                    "child": node,
                    "cut": True,
                    "depth_m": round(removed, 4),
                    "why": "the parent's convex pieces filled a concavity of its mesh under the child",
                }
            )
    return [((parent.rotation.T @ v.T).T, f) for v, f in work], entries


def clip_to_mesh(place: Placement, pieces: list[Piece]) -> tuple[list[Piece], float]:
    """Pieces cut to the mesh's extent along the asset axes, the world's up and down and ``CLIP_DIRECTIONS``
    horizontal world directions (a discrete oriented polytope of the mesh): a decomposition's piece never
    reaches past the mesh it approximates in those directions. Returns the pieces and the largest distance
    (m) a piece reached past them."""
    angles = np.arange(CLIP_DIRECTIONS) * 2 * np.pi / CLIP_DIRECTIONS
    world_dirs = np.vstack([np.c_[np.cos(angles), np.sin(angles), np.zeros_like(angles)], [[0, 0, 1.0], [0, 0, -1.0]]])
    dirs = np.vstack([np.eye(3), -np.eye(3), world_dirs @ place.rotation])  # body frame
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
    place: Placement, pieces: list[Piece], mass: float = 1.0, load: Iterable[tuple[float, NDArray]] = ()
) -> tuple[Piece | None, dict[str, Any] | None]:
    """A footing piece (body frame) for an object that would rock on its lowest points, and its report
    entry; (None, None) when it stands as it is. ``load``: (mass kg, world centre of mass) of what rests
    on the object (its children, theirs, ...), whose weight it carries; ``mass``: its own (kg)."""
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
        entry = {
            "band_m": round(band, 4),
            "band_fraction_of_height": frac,
            "support_margin_before_m": round(margin, 4),
            "support_margin_after_m": round(held, 4),
            "why": "its centre of mass (with what rests on it) is not over the points it stands on (an uneven "
            "generated bottom): the hull of its lowest band, down to its lowest point, is added",
        }
        return piece, entry
    return None, {
        "band_m": None,
        "support_margin_before_m": round(margin, 4),
        "why": f"none added: no band up to {FOOTING_BANDS[-1]:g} of its height holds its centre of mass",
    }


def edit_colliders(
    objects: list[ExportObject],
    pieces: dict[str, list[Piece]],
    hollow: dict[str, tuple[list[Piece], dict[str, Any]]],
    graph: SceneGraph | None,
    kinds: dict[str, str],
    methods: dict[str, str],
    masses: dict[str, float] | None = None,
) -> dict[str, ColliderEdits]:
    """Apply the edits of the module doc to ``pieces`` (node -> body-frame decomposition pieces, changed in
    place): clipping to the mesh (CoACD and hull pieces; ``methods``: node -> decomposition method), hollow
    shells (computed by ``find_hollow``), completions, seats, footings, in that order. ``masses``: node ->
    kg, for the load a footing carries (1 kg each when not given)."""
    places = {o.node_name: placement(o) for o in objects}
    by_instance = {int(o.instance): o for o in objects}
    edits = {o.node_name: ColliderEdits() for o in objects}
    for obj in objects:
        name = obj.node_name
        if name in hollow:
            pieces[name] = list(hollow[name][0])
            edits[name].hollow = hollow[name][1]
        elif methods.get(name) not in ("components", "shell"):
            pieces[name], reach = clip_to_mesh(places[name], pieces[name])
            if reach > 1e-4:
                edits[name].clipped_m = round(reach, 4)
        extra, entries = completion_pieces(obj, places[name])
        pieces[name] = list(pieces[name]) + extra
        edits[name].completions = entries
    for obj in objects:
        kids = [by_instance[c] for c in _children(obj.instance, graph) if c in by_instance]
        if not kids or obj.node_name in hollow:  # a shell's boards are at its children's feet already
            continue
        name = obj.node_name
        pieces[name], edits[name].seats = seat_children(
            places[name], pieces[name], [(k.node_name, places[k.node_name]) for k in kids]
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
        piece, entry = footing(places[name], pieces[name], masses.get(name, 1.0), load)
        if entry is not None and load:
            entry["load_kg"] = round(sum(m for m, _ in load), 3)
        if piece is not None:
            pieces[name].append(piece)
        edits[name].footing = entry
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
        kids = [placement(by_instance[c]) for c in _children(obj.instance, graph) if c in by_instance]
        found = hollow_shell(obj, placement(obj), kids, shell)
        if found is not None:
            out[obj.node_name] = found
    return out
