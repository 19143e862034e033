"""Seats: a child's prism carved out of its parent's pieces where the parent's own geometry is not, and
boards extended under a child's foot (see ``rescene_core.colliders.edits``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import trimesh
from numpy.typing import NDArray
from shapely.geometry import MultiPoint, Polygon

from rescene_core.colliders.pieces import (
    BOARD_THICKNESS,
    CARVE_MARGIN,
    Piece,
    Placement,
    carve,
    footprint_ring,
    hull_piece,
    inside_piece,
)

SEAT_MESH_TOLERANCE = 0.02
"""A child whose parent's mesh rises more than this (m) above the child's bottom under its foot (the support
contact tolerance of the structural metrics) is inside the mesh: its parent's pieces are not cut."""


SEAT_RIDGE_SHARE = 1.0 / 3.0
"""A parent's mesh rising more than SEAT_MESH_TOLERANCE inside a child under at most this share of the child's
footprint (the hull of its surface there, against the footprint moved in by SEAT_INSET) is a ridge or a bump
of a generated mesh, not a child sunk into its parent: the child, seen standing on the rest of the face, keeps
its seat and the parent's pieces are carved (the report keeps the mesh overlap). Cluttered diagnostic seed
205: a book stack across a 4 cm wide, 2.3 cm high ridge of a generated cabinet's top started 22.6 mm into it
and slid off."""


SEAT_FOOT = 0.02
"""A child's foot: its points within this height (m) of its lowest one; a board under it covers them."""


SEAT_INSET = 0.01
"""Parent mesh points within this distance (m) inside the edge of a child's footprint do not count as inside
the child (a face touching its side)."""


SUPPORT_MATCH = 0.03
"""A support plane within this distance (m) of a child's bottom is the board the child stands on."""


SEAT_FLOOR_PROBE = 0.005
"""After a seat is cut, the parent still carries a child that rests on it when its pieces hold the points of
the child's foot this far (m) below its bottom; where they hold none (the cut went through a panel thinner
than the seat, as a hollow shell's top), the seat gets a floor: a board across the seat at the child's bottom."""


def _surface_samples(place: Placement) -> NDArray[np.float64]:
    """World points of the mesh's surface: its vertices, face centres and 4000 area-weighted samples."""
    mesh = trimesh.Trimesh(place.world(place.vertices), place.faces, process=False)
    return np.vstack([mesh.vertices, mesh.triangles_center, mesh.sample(4000, seed=0)])


def _inner(ring: NDArray) -> Polygon:
    """A child's footprint ``ring`` [k, 2] with its sides moved in by SEAT_INSET (a face touching its side is
    not inside it)."""
    return Polygon(ring).buffer(-SEAT_INSET, join_style="mitre")


def _samples_inside(samples: NDArray, inner: Polygon, z_lo: float, z_hi: float) -> NDArray:
    """The ``samples`` [n, 3] over ``inner`` (not empty) with z in (z_lo, z_hi] [m, 3]."""
    z = samples[:, 2]
    near = samples[(z > z_lo) & (z <= z_hi)]
    return near[shapely.contains_xy(inner, near[:, 0], near[:, 1])]


def mesh_overlap(samples: NDArray, mesh: trimesh.Trimesh | None, ring: NDArray, z_lo: float, z_hi: float) -> float:
    """How high (m) a parent's mesh rises above ``z_lo`` inside a child's prism (``ring`` [k, 2], up to
    ``z_hi``, its sides moved in by ``SEAT_INSET``): the highest of its surface ``samples`` there, the whole
    height when the (closed) ``mesh`` contains the prism's centre; 0 when the mesh is not there."""

    inner = _inner(ring)
    rise = 0.0
    if not inner.is_empty:
        inside = _samples_inside(samples, inner, z_lo, z_hi)
        if len(inside):
            rise = float(inside[:, 2].max()) - z_lo
    if mesh is not None and mesh.is_watertight:
        centre = np.r_[np.asarray(Polygon(ring).centroid.coords)[0], 0.5 * (z_lo + z_hi)]
        if bool(mesh.contains(centre[None])[0]):
            rise = max(rise, z_hi - z_lo)
    return rise


def raised_share(samples: NDArray, ring: NDArray, z_lo: float, z_hi: float) -> float:
    """Share of a child's footprint (``ring`` [k, 2] moved in by SEAT_INSET) under which its parent's surface
    ``samples`` [n, 3] rise more than SEAT_MESH_TOLERANCE above ``z_lo`` (up to ``z_hi``): the area of their
    convex hull inside it over its area."""
    inner = _inner(ring)
    if inner.is_empty:
        return 1.0
    high = _samples_inside(samples, inner, z_lo + SEAT_MESH_TOLERANCE, z_hi)
    if len(high) < 3:
        return 0.0
    return float(MultiPoint(high[:, :2]).convex_hull.intersection(inner).area / inner.area)


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

    boards_xy = [(h, MultiPoint(np.asarray(xy, np.float64)).convex_hull.buffer(1e-3)) for h, xy in supports]
    entries, boards = [], []
    off = parent.translation
    work: list[Piece] = [((parent.rotation @ v.T).T, f) for v, f in pieces]  # world-oriented, origin at the body
    samples, mesh = None, None
    children_list = list(children)
    for child in children_list:
        cw = np.vstack([child.place.world(child.place.vertices)] + [child.place.world(v) for v, _ in child.pieces])
        bottom, top = float(cw[:, 2].min()), float(cw[:, 2].max())
        ring = footprint_ring(cw[:, :2], CARVE_MARGIN)
        local = ring - off[:2]
        carved, depth = carve(work, local, bottom - off[2], top + CARVE_MARGIN - off[2])
        board = next((b for b in boards_xy if abs(b[0] - bottom) <= SUPPORT_MATCH), None) if child.direct else None
        foot = cw[cw[:, 2] <= bottom + SEAT_FOOT]
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
            # a mesh containing the prism's centre rises through the whole child: not a ridge
            elif rise < top - bottom and (share := raised_share(samples, ring, bottom, top)) <= SEAT_RIDGE_SHARE:
                entry["raised_share"] = round(share, 3)
                why = (
                    f"the parent's mesh rises {rise:.3f} m above the child's bottom under {share:.0%} of its "
                    "footprint only (a ridge of the generated mesh; the child was seen standing on the rest)"
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
            if child.direct and board is None and not _holds(work, foot, bottom, off):
                # the floor spans the whole seat, not only the foot: a footing added later may widen the
                # child's base past its lowest points; it keeps out of neighbours and the other children
                near = [s.place.world(s.place.vertices) for s in children_list if s is not child]
                if others is not None:
                    near.append(others)
                piece = _foot_board(ring, bottom, off, np.vstack(near) if near else None)
                if piece is not None:
                    work.append(piece)
                    boards.append(
                        {
                            "child": child.node,
                            "height_m": round(bottom, 4),
                            "support_plane_m": None,
                            "why": "the seat went through the parent's pieces under a child seen resting on it: "
                            f"a floor {BOARD_THICKNESS * 100:g} cm thick across the seat at the child's bottom",
                        }
                    )
        fring = footprint_ring(foot[:, :2], 0.0)
        if board is not None and not Polygon(fring).within(board[1]):  # the foot reaches past the board
            piece = _foot_board(fring, bottom, off, others)
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


def _holds(work: list[Piece], foot: NDArray, bottom: float, off: NDArray) -> bool:
    """Whether any of the parent's pieces (world-oriented, origin at the body ``off``) holds a point of the
    child's ``foot`` (world [n, 3]) ``SEAT_FLOOR_PROBE`` below the child's ``bottom``."""
    probe = np.c_[foot[:, :2], np.full(len(foot), bottom - SEAT_FLOOR_PROBE)] - off
    return any(inside_piece(probe, piece, tolerance=1e-6).any() for piece in work)


def _foot_board(fring: NDArray, bottom: float, off: NDArray, others: NDArray | None) -> Piece | None:
    """A slab ``BOARD_THICKNESS`` thick under a ring (world xy [k, 2]: a foot, a seat) with its top at ``bottom``,
    in the parent's world-oriented frame; None where it is degenerate or a neighbour's geometry (``others``,
    world [n, 3]) reaches into it (the board would not be the child's alone)."""
    ring = fring - off[:2]
    level = bottom - off[2]
    slab = np.vstack([np.c_[ring, np.full(len(ring), level)], np.c_[ring, np.full(len(ring), level - BOARD_THICKNESS)]])
    piece = hull_piece(slab)
    if piece is not None and others is not None and len(others):
        if inside_piece(others, (piece[0] + off, piece[1])).any():
            return None
    return piece
