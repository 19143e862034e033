"""Collision pieces the layout adds to an object's decomposition, and the pieces it changes (MJCF and USD).

All pieces here are in the object's body frame: the asset frame scaled by the pose's scale (metres), rotated
and translated by the pose's rotation and translation (rescene_core/export/mjcf.py). Every change is listed
in ``scene/export_report.json`` under the object.

* **Clipping.** A CoACD or hull piece is cut to the mesh's extent along its asset axes, the world's up and
  down and 24 horizontal world directions: a decomposition never reaches past the mesh it approximates in
  those directions. (CoACD's excess on the benchmark scenes lies inside that extent, where a piece fills a
  concavity: the seats below handle the part of it under a child, rescene_core/colliders/separate.py the part
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
  room); else (no room) the side nearest the children's centre. A child inside standing on a shelf of the
  mesh where the layout found no support plane keeps it as a board (``hollow.mesh_shelves``).
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
* **Flat bases.** A free object resting on something stands on its lowest points: its pieces' vertices within
  ``FLAT_BASE_BAND`` of the lowest one are lowered onto it, one flat base (``footing.flat_base``: a
  decomposition's bottom is uneven by millimetres, and the simulator's face contact keeps one facet of it).
* **Footings.** A free object resting on something stands on its lowest points. A generated mesh's bottom
  is its generator's invention, often uneven: when the centre of mass (of its collision pieces) is not
  over the polygon of its points within ``CONTACT_BAND`` of the lowest one (shrunk by ``FOOTING_MARGIN``),
  it would rock or tip at once (the centre counted with everything resting on it, at their masses: a table
  carries the monitor at its corner). It then gets a footing: the hull of its vertices in the lowest band of its
  height and of the same vertices on the level of its lowest point, with the band grown (``FOOTING_BANDS``
  of the height, up to half of it: a generated lamp's head beside its foot) until the centre is over the
  footing's bottom far enough to resist a tilt of ``FOOTING_TILT_DEG`` (the rotation the physics check
  still calls stable: a centre 14 cm up and 1 cm inside tips at 4 deg), else, when no band does, the first
  band that holds it ``FOOTING_MARGIN`` inside. When no band holds it and it carries something, a plinth:
  the prism under the plan of all its pieces (the boards under what it carries included), from its lowest
  point to just under the lowest board it carries (``footing.plinth``: a cabinet generated from its front
  as a slab, under books the capture saw further back). When nothing holds it, nothing is added and the
  report says so.
* **Neighbours** (rescene_core/colliders/separate.py): pieces of two objects, neither resting on the other,
  that overlap where neither object's mesh or completions are, are cut apart by a plane between the two,
  or, when no plane separates them, the piece filling a concavity the other stands in is carved there;
  when neither works, one piece gives way to the other (convex subtraction).
* **Walls** (rescene_core/colliders/walls.py): a free object's piece that reaches into the box behind a wall's
  plane by at most ``walls.MAX_DEPTH`` is cut at the plane.

Seats are carved deepest carrier first, so a child's board under its own child is one of its pieces when
its parent carves its seat.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.colliders.footing import flat_base, footing
from rescene_core.colliders.hollow import resting_descendants, within_pulled_sides
from rescene_core.colliders.pieces import (
    BOARD_THICKNESS,
    Piece,
    PlacedMesh,
    Placement,
    centre_of_mass,
    clip_to_mesh,
    hull_piece,
    placement,
)
from rescene_core.colliders.seats import Seated, seat_children
from rescene_core.colliders.separate import evidence_points, separate
from rescene_core.colliders.walls import clear_of_walls, trimmed_walls, walls_report
from rescene_core.geometry.completion import completion_solid
from rescene_core.records import CompletionKind, InstanceId, Relation, RoomShell, SceneGraph


@dataclass
class ColliderEdits:
    """What this module did to one object's pieces (the export report's entry)."""

    completions: list[dict[str, Any]] = field(default_factory=list)
    hollow: dict[str, Any] | None = None
    seats: list[dict[str, Any]] = field(default_factory=list)
    boards: list[dict[str, Any]] = field(default_factory=list)
    flat_base: dict[str, Any] | None = None
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
            "flat_base": self.flat_base,
            "footing": self.footing,
            "separated_from_neighbours": self.separated,
            "cut_at_walls": self.walls,
        }


def completion_pieces(obj: PlacedMesh, place: Placement) -> tuple[list[Piece], list[dict[str, Any]]]:
    """Body-frame pieces of ``obj``'s completions and their report entries (a flat or degenerate one is
    reported and left out)."""
    pieces, entries = [], []
    for c in obj.completions:
        if c.kind not in (CompletionKind.SUPPORT_PLANE, CompletionKind.BASE):
            continue  # applied to the mesh itself (a cut), not a collider of its own
        solid = completion_solid(c, obj.world_from_asset, BOARD_THICKNESS)
        hull = hull_piece(solid * place.scale)
        entry: dict[str, Any] = {
            "kind": c.kind.value,
            "source": c.source,
            "evidence_derived": True,
            "collider": f"board {BOARD_THICKNESS * 100:g} cm thick below the plane"
            if c.kind is CompletionKind.SUPPORT_PLANE
            else "convex hull of the base's points",
        }
        world_z = place.world(np.asarray(c.points_asset) * place.scale)[:, 2]
        if c.kind is CompletionKind.SUPPORT_PLANE:
            entry["height_m"] = round(float(world_z.mean()), 4)
        else:
            entry["span_z_m"] = [round(float(world_z.min()), 4), round(float(world_z.max()), 4)]
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


def edit_colliders(
    objects: Sequence[PlacedMesh],
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
    shells (computed by ``find_hollow``), completions, seats, flat bases and footings, free bodies' pieces cut
    at the walls of ``shell`` they graze (rescene_core/colliders/walls.py), neighbours cut apart, in that
    order.
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
    evidence = {o.node_name: evidence_points(places[o.node_name], added[o.node_name]) for o in objects}
    related = {
        frozenset((o.node_name, by_instance[d].node_name))
        for o in objects
        for d in resting_descendants(o.instance, graph)
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
        edge = parents.get(InstanceId(obj.instance))
        if kinds.get(name) != "free" or edge is None or edge.relation != Relation.RESTS_ON:
            continue
        pieces[name], edits[name].flat_base = flat_base(places[name], pieces[name])
        load = carried(int(obj.instance), frozenset({int(obj.instance)}))
        bottoms = [
            float(places[n].world(np.vstack([v for v, _ in pieces[n]]))[:, 2].min())
            for n in (by_instance[c].node_name for c in _children(obj.instance, graph) if c in by_instance)
            if pieces.get(n)
        ]
        piece, entry = footing(
            places[name], pieces[name], masses.get(name, 1.0), load, others_of(name), min(bottoms, default=None)
        )
        if entry is not None and load:
            entry["load_kg"] = round(sum(m for m, _ in load), 3)
        if piece is not None:
            pieces[name].append(piece)
        edits[name].footing = entry
    walls = trimmed_walls(shell)
    for name in pieces:
        if kinds.get(name) == "free":
            pieces[name], cut = clear_of_walls(places[name], pieces[name], walls)
            edits[name].walls = walls_report(cut)
    for name, rows in separate(places, pieces, evidence, related, added).items():
        edits[name].separated = rows
    return edits
