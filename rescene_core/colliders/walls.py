"""Free objects' collision pieces kept out of the wall boxes they graze.

Attachment counts a footprint up to ``containment_tolerance`` (1 cm) beyond the floor polygon as inside the
room, and a generated mesh standing against a wall often reaches a few millimetres through it. The simulator
has a solid box behind each wall's plane (``shell.wall_boxes``): a free body starting 5-10 mm inside one is
pushed out at t = 0, and a tall one (a floor lamp in a corner) tips over. A piece of a free body that crosses
a wall's plane by at most ``MAX_DEPTH``, where the wall's box is (along its trimmed extent,
``shell.wall_extent``), is cut at the plane and keeps its room side (a convex piece cut by a plane stays
convex). A deeper crossing of the mesh itself is a layout fault: its pieces are left as they are, and the
physics check reports it. A piece the export added (a board under a child's foot, a base, a plinth) that
crosses deeper while the mesh does not is cut whatever its depth: a desk's board under a monitor whose foot
was registered behind the wall reached 64 mm into it.
Crossings of a fraction of a millimetre are cut too: a position-based solver (Newton's XPBD) turns a t = 0
overlap into velocity, depth / time step, and a book stack 1.6 mm into a wall left it at 1 m/s and fell 44 cm.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.colliders.pieces import Piece, Placement, edge_crossings, is_solid, slice_piece
from rescene_core.geometry.room import wall_extent
from rescene_core.records import RoomShell, WallPlane

MAX_DEPTH = 0.02
"""Deepest crossing (m) cut away: twice the containment tolerance attachment accepts."""

MIN_CUT_DEPTH = 1e-4
"""Shallowest crossing (m) cut: below it the contact is at rest within the engines' own tolerances."""

TrimmedWall = tuple[WallPlane, NDArray[np.float64], NDArray[np.float64], float]
"""A wall, the start [2] of its trimmed extent, the unit tangent [2] along it and its length (m)."""


def trimmed_walls(shell: RoomShell | None) -> list[TrimmedWall]:
    """The walls of ``shell`` with their trimmed extents (``shell.wall_extent``), once per scene."""
    out: list[TrimmedWall] = []
    if shell is None:
        return out
    for wall in shell.walls:
        extent = wall_extent(shell, wall)
        if extent is None:
            continue
        start, end = np.asarray(extent[0], np.float64), np.asarray(extent[1], np.float64)
        length = float(np.linalg.norm(end - start))
        if length > 0:
            out.append((wall, start, (end - start) / length, length))
    return out


def clear_of_walls(
    place: Placement, pieces: list[Piece], walls: list[TrimmedWall]
) -> tuple[list[Piece], dict[str, float]]:
    """``pieces`` (body frame) cut at the planes of the ``walls`` (``trimmed_walls``) whose boxes they reach
    into by at most ``MAX_DEPTH``, or by any depth where the object's mesh itself keeps within ``MAX_DEPTH``
    of the plane (the piece is one the export added); returns the pieces and {wall id: deepest crossing cut
    (m)}."""
    out = list(pieces)
    cut: dict[str, float] = {}
    mesh = place.world(place.vertices)
    for wall, start, tangent, length in walls:
        normal = np.asarray(wall.plane.normal, np.float64)
        origin = -float(wall.plane.offset) * normal
        # the layout's own crossing: when the mesh keeps within MAX_DEPTH of the plane, a deeper piece is one the
        # export added (a board under a child's foot registered behind the wall), cut whatever its depth
        mesh_signed = mesh @ normal + float(wall.plane.offset)
        mesh_along = (mesh[:, :2] - start) @ tangent
        on_wall = (mesh_along >= 0) & (mesh_along <= length)
        limit = MAX_DEPTH if (mesh_signed[on_wall] < -MAX_DEPTH).any() else np.inf
        for k, piece in enumerate(out):
            world = place.world(piece[0])
            signed = world @ normal + float(wall.plane.offset)
            if not (signed < -MIN_CUT_DEPTH).any():
                continue
            # where the piece's volume is behind the plane: its vertices there and where its edges cross the plane
            # (a piece reaching past the end of a wall's box crosses the box's end edge between its vertices)
            behind = np.vstack([world[signed < 0], edge_crossings((world, piece[1]), -signed)])
            along = (behind[:, :2] - start) @ tangent
            depth = float(-signed.min())
            if depth > limit or along.max() < 0 or along.min() > length:
                continue  # a layout fault, or the plane beyond the wall's box (another wing of the room)
            kept = slice_piece((world, piece[1]), normal, origin)
            if not is_solid(kept):
                continue
            out[k] = (place.body(kept[0]), kept[1])
            cut[str(wall.id)] = round(max(cut.get(str(wall.id), 0.0), depth), 4)
    return out, cut


def walls_report(cut: dict[str, float]) -> dict[str, Any] | None:
    """The export report's entry for one object's pieces cut at walls (None: none cut)."""
    if not cut:
        return None
    return {
        "depth_m": cut,
        "why": "its pieces reached into the box behind a wall's plane (the room's attachment tolerance): cut at "
        "the plane",
    }
