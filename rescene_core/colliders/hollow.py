"""Hollow parents: a generated parent with a support plane inside its mesh and a child standing in it gets
a shell of panels around its bounding box, one side open (see ``rescene_core.colliders.edits``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.colliders.pieces import (
    BOARD_THICKNESS,
    WORLD_UP,
    Piece,
    PlacedMesh,
    Placement,
    clip_to_mesh,
    hull_piece,
    is_solid,
    placement,
    slice_piece,
)
from rescene_core.colliders.seats import SUPPORT_MATCH
from rescene_core.records import CompletionKind, InstanceId, Relation, RoomShell, SceneGraph

PANEL_THICKNESS = 0.02
"""Thickness (m) of a hollow parent's panels (at most a quarter of the box's extent on that axis)."""


INSIDE_MARGIN = 0.05
"""A support plane more than this (m) below the mesh's top is inside the mesh (a shelf, not the top)."""


BACK_WALL_MAX = 0.30
"""A side of a hollow parent within this distance (m) of a wall it faces (within 30 deg), in front of the
wall's segment (up to this far past its ends), backs onto it."""


UPRIGHT_COS = float(np.cos(np.radians(10.0)))
"""A hollow shell needs an asset axis within 10 deg of the world's up."""


SHELF_MATCH = 0.015
"""A child inside a hollow parent whose bottom is within this height (m) of upward faces of the parent's mesh
stands on that shelf of the mesh."""


def mesh_shelves(place: Placement, bottoms: Sequence[float], skip: Sequence[float]) -> list[tuple[float, Piece]]:
    """Boards (body frame) under children inside a hollow parent that stand on a shelf of its generated mesh:
    for each child bottom in ``bottoms`` (world m) not within SUPPORT_MATCH of a height in ``skip`` (the layout's
    support planes, which become boards of their own, and the bottom panel), the upward faces of the mesh
    (normal within 10 deg of up) within SHELF_MATCH of it, as a board BOARD_THICKNESS thick under the hull of
    their plan, its top at the child's bottom. Children on one shelf share its board. The shell's panels are
    the mesh's box: a shelf the layout found no points of (a book stack on the mesh's middle shelf, cluttered
    diagnostic seed 206) was lost with the decomposition, and what stood on it fell to the shelf below."""
    world_v = place.world(place.vertices)
    mesh = trimesh.Trimesh(world_v, place.faces, process=False)
    up = mesh.face_normals[:, 2] > UPRIGHT_COS
    if not up.any():
        return []
    corners = world_v[place.faces[up]]
    face_z = corners[:, :, 2].mean(axis=1)
    out: list[tuple[float, Piece]] = []
    for bottom in sorted(bottoms):
        if any(abs(bottom - h) <= SUPPORT_MATCH for h in [*skip, *(h for h, _ in out)]):
            continue
        on = np.abs(face_z - bottom) <= SHELF_MATCH
        if not on.any():
            continue
        plan = corners[on].reshape(-1, 3)[:, :2]
        board = np.vstack(
            [np.c_[plan, np.full(len(plan), bottom)], np.c_[plan, np.full(len(plan), bottom - BOARD_THICKNESS)]]
        )
        piece = hull_piece(place.body(board))
        if piece is not None:
            out.append((bottom, piece))
    return out


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
            cut = slice_piece(cut, normal, origin) if cut is not None else None
        out.append(cut if cut is not None and is_solid(cut) else piece)
    return out


def hollow_shell(
    obj: PlacedMesh,
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
    inside, bottoms = [], []
    for child in children:
        cw = child.world(child.vertices)
        cv = place.body(cw)
        bottom = float(cv[:, k].min() if up[k] > 0 else -cv[:, k].max())
        overlaps = all(cv[:, a].min() < hi[a] and cv[:, a].max() > lo[a] for a in horizontal)
        if overlaps and bottom < level - INSIDE_MARGIN:
            inside.append(cv.mean(axis=0))
            bottoms.append(float(cw[:, 2].min()))
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
    floor_panel = float(world_v[:, 2].min()) + float(t[k])
    shelves = mesh_shelves(place, bottoms, [*inner, floor_panel])
    pieces += [piece for _, piece in shelves]
    pieces, reach = clip_to_mesh(place, pieces)  # a turned mesh's box reaches past the mesh
    axis = "xyz"[open_side[0]]
    entry = {
        "open_side": f"{'+' if open_side[1] > 0 else '-'}{axis} (asset frame)",
        "open_side_world": np.round(normal_world(*open_side), 4).tolist(),
        "reason": reason,
        "panel_thickness_m": round(float(t.min()), 4),
        "inner_support_planes_m": [round(h, 4) for h in inner],
        "shelves_from_mesh_m": [round(h, 4) for h, _ in shelves],
        "children_inside": len(inside),
        "clipped_to_extent_m": round(reach, 4),
        "pulled_out_of_walls_m": pulled,
        "why": "a support plane inside the generated mesh with children standing in it: solid pieces would push "
        "them out",
    }
    return pieces, entry


def find_hollow(
    objects: Sequence[PlacedMesh], graph: SceneGraph | None, shell: RoomShell | None
) -> dict[str, tuple[list[Piece], dict[str, Any]]]:
    """Node -> (shell pieces, report entry) of every hollow parent (see ``hollow_shell``)."""
    by_instance = {int(o.instance): o for o in objects}
    out = {}
    for obj in objects:
        if not any(c.kind is CompletionKind.SUPPORT_PLANE for c in obj.completions):
            continue
        kids = [placement(by_instance[c]) for c in resting_descendants(obj.instance, graph) if c in by_instance]
        found = hollow_shell(obj, placement(obj), kids, shell)
        if found is not None:
            out[obj.node_name] = found
    return out


def resting_descendants(instance: int, graph: SceneGraph | None) -> list[int]:
    """What rests on it, then on those (breadth first; none without a graph)."""
    return [] if graph is None else [int(c) for c in graph.descendants(InstanceId(int(instance)), Relation.RESTS_ON)]
