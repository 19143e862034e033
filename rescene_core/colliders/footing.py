"""What a free object resting on something stands on: its pieces' lowest vertices levelled into one flat
base, and, when its centre of mass is not over the points it stands on, the hull of its lowest band, or, when
no band holds it and it carries things that stand past its body, a plinth under what it carries (see
``rescene_core.colliders.edits``).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import MultiPoint, Point

from rescene_core.colliders.pieces import (
    BOARD_THICKNESS,
    NEIGHBOUR_CLEARANCE,
    Piece,
    Placement,
    centre_of_mass,
    horizontal_directions,
    hull_piece,
    inside_piece,
    slice_piece,
)

CONTACT_BAND = 0.001
"""Collider points within this height (m) of the lowest one are the points an object stands on."""


FOOTING_MARGIN = 0.01
"""The centre of mass must be this far (m) inside the polygon an object stands on."""


FOOTING_TILT_DEG = 5.0
"""A footing holds the centre of mass at least (its height above the footing) x tan(this) inside, when a band
can (deg): the rotation the physics check still counts as stable."""


FOOTING_BANDS = (0.02, 0.05, 0.10, 0.15, 0.25, 0.35, 0.5)
"""Heights of the footing's band, as fractions of the object's height (the first that holds is used)."""


FOOTING_MIN_BAND = 0.01
"""Smallest band of a footing (m)."""


PLINTH_CLEARANCE = 0.002
"""Gap (m) between a plinth's top and the bottom of the lowest board what the object carries stands on."""


FLAT_BASE_BAND = 0.002
"""Collider vertices within this height (m) of an object's lowest one are lowered onto its level: its base.
A decomposition's bottom follows the generated mesh's, uneven by a millimetre or two, so the lowest face of a
piece is one small facet of its base; MuJoCo's face contact (multi-point, ``multiccd``) clips that one face
against the support and keeps at most four points of it, so the object stands on a sliver of its base and
rocks over its edge. Standard diagnostic seed 212: a potted plant's pot stood on 15 vertices spread over
19 x 30 cm within 2 mm of its lowest point; MuJoCo's contacts covered 7 x 18 cm of it, 4 mm short of the
centre of mass, and the plant tipped over. Lowering a vertex by at most this much reaches no further into a
flat support than the contact tolerance of the structural metrics."""


def flat_base(place: Placement, pieces: list[Piece]) -> tuple[list[Piece], dict[str, Any] | None]:
    """``pieces`` (body frame) with every vertex within FLAT_BASE_BAND of their lowest world height lowered
    onto it (each piece so changed is the convex hull of its moved vertices), and the report entry (None when
    nothing moved by more than 0.01 mm)."""
    if not pieces:
        return pieces, None
    worlds = [place.world(v) for v, _ in pieces]
    zmin = min(float(w[:, 2].min()) for w in worlds)
    out: list[Piece] = []
    moved, deepest = 0, 0.0
    for (v, f), world in zip(pieces, worlds, strict=True):
        low = (world[:, 2] > zmin + 1e-5) & (world[:, 2] <= zmin + FLAT_BASE_BAND)
        hull = None
        if low.any():
            deepest = max(deepest, float(world[low, 2].max()) - zmin)
            world[low, 2] = zmin
            hull = hull_piece(place.body(world))
        if hull is None:
            out.append((v, f))
            continue
        moved += int(low.sum())
        out.append(hull)
    if not moved:
        return pieces, None
    return out, {
        "level_m": round(zmin, 4),
        "vertices_lowered": moved,
        "max_lowered_m": round(deepest, 4),
        "why": f"the collider's vertices within {FLAT_BASE_BAND * 1000:g} mm of its lowest point are lowered onto "
        "it: one flat base instead of facets a millimetre apart, of which the simulator's face contact keeps one",
    }


def _support_margin(points_xy: NDArray, centre_xy: NDArray) -> float:
    """Signed distance (m) of ``centre_xy`` inside the convex hull of ``points_xy`` (negative: outside)."""

    hull = MultiPoint(points_xy).convex_hull
    if hull.geom_type != "Polygon":
        return -float(hull.distance(Point(centre_xy))) - 1e-9
    p = Point(centre_xy)
    return float(hull.exterior.distance(p)) if hull.contains(p) else -float(hull.exterior.distance(p))


HORIZONTAL_DIRECTIONS = 24
"""Vertical planes tried (their horizontal normals) to cut a footing clear of a neighbour."""


def _clear_of(
    piece: Piece, intruding: NDArray, others: NDArray, com_xy: NDArray, zmin: float
) -> tuple[Piece, float] | None:
    """A footing ``piece`` (world) cut by a vertical plane NEIGHBOUR_CLEARANCE before the neighbours' points
    ``intruding`` [k, 3] it reaches into, keeping the side that holds the centre of mass ``com_xy`` [2] at
    least FOOTING_MARGIN inside its contact points (at ``zmin``) and no point of ``others`` [n, 3]; of the
    HORIZONTAL_DIRECTIONS planes, the one holding it furthest inside. Returns (the cut piece, its support
    margin m), or None when no plane does. A monitor's band reached 5 mm past its mesh into one point of what
    stood behind it (cluttered diagnostic seed 205), and it tipped over with no footing."""
    best: tuple[Piece, float] | None = None
    for d in horizontal_directions(HORIZONTAL_DIRECTIONS):
        level = float((intruding @ d).min()) - NEIGHBOUR_CLEARANCE
        if float(np.r_[com_xy, 0.0] @ d) > level:
            continue  # the plane would leave the centre of mass outside
        kept = slice_piece(piece, -d, level * d)
        if kept is None or len(kept[0]) < 4 or inside_piece(others, kept).any():
            continue
        low = kept[0][kept[0][:, 2] <= zmin + CONTACT_BAND]
        if len(low) < 3:
            continue
        held = _support_margin(low[:, :2], com_xy)
        if held >= FOOTING_MARGIN and (best is None or held > best[1]):
            best = (kept, held)
    return best


def footing(
    place: Placement,
    pieces: list[Piece],
    mass: float = 1.0,
    load: Iterable[tuple[float, NDArray]] = (),
    others: NDArray | None = None,
    carried_from: float | None = None,
) -> tuple[Piece | None, dict[str, Any] | None]:
    """A footing piece (body frame) for an object that would rock on its lowest points, and its report
    entry; (None, None) when it stands as it is. ``load``: (mass kg, world centre of mass) of what rests
    on the object (its children, theirs, ...), whose weight it carries; ``mass``: its own (kg). ``others``:
    world points [n, 3] of neighbours' geometry (meshes, completions), which a footing must not reach into
    (a band that would is skipped). ``carried_from``: the world height (m) of the lowest bottom among the
    objects resting on it (None when nothing does), the top a plinth stays under (``plinth``)."""
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
        piece = hull_piece(place.body(np.vstack([low, flat])))
        if piece is None:
            continue
        cleared = False
        if others is not None and len(others):
            world = (place.world(piece[0]), piece[1])
            intruding = others[inside_piece(others, world)]
            if len(intruding):
                clear = _clear_of(world, intruding, others, com_w[:2], zmin)
                if clear is None:
                    blocked = True
                    continue
                (kept, faces), held = clear
                piece, cleared = (place.body(kept), faces), True
        entry = {
            "band_m": round(band, 4),
            "band_fraction_of_height": frac,
            "support_margin_before_m": round(margin, 4),
            "support_margin_after_m": round(held, 4),
            "tilt_margin_m": round(float(tilt_margin), 4),
            "why": "its centre of mass (with what rests on it) is not over the points it stands on (an uneven "
            "generated bottom): the hull of its lowest band, down to its lowest point, is added"
            + (", cut clear of a neighbour it reached into" if cleared else ""),
        }
        if held >= tilt_margin:
            return piece, entry
        holding.append((piece, entry))
    if holding:  # none resists the tilt: the first that holds the centre at all
        return holding[0]
    if carried_from is not None:
        block, said = plinth(place, cw, com_w, carried_from, others)
        if block is not None and said is not None:
            return block, said | {"support_margin_before_m": round(margin, 4)}
        blocked = blocked or said is not None
    return None, {
        "band_m": None,
        "support_margin_before_m": round(margin, 4),
        "why": f"none added: no band up to {FOOTING_BANDS[-1]:g} of its height holds its centre of mass"
        + (" without reaching into a neighbour" if blocked else ""),
    }


def plinth(
    place: Placement,
    cw: NDArray,
    com_w: NDArray,
    carried_from: float,
    others: NDArray | None,
) -> tuple[Piece | None, dict[str, Any] | None]:
    """A plinth (body frame) under everything an object's collider (``cw``: its pieces' vertices, world [n, 3])
    spans in plan, from its lowest point up
    to just under the boards what it carries stands on (``carried_from`` less a board and
    ``PLINTH_CLEARANCE``), when that holds ``com_w`` (world, with its load) ``FOOTING_MARGIN`` inside and
    reaches into none of ``others``. (None, None) when it would not hold the centre or has no height; (None,
    entry) when it would reach into a neighbour.

    The case: a body generated from one side only (a cabinet seen from the front is a 4 cm slab, a shelf
    seen from the front 9 cm deep) under things the capture saw standing 20-30 cm further back; their boards
    reach past the body, which tips under their weight. The capture says the object carries them there, so
    its body reaches under them."""
    zmin = float(cw[:, 2].min())
    top = carried_from - BOARD_THICKNESS - PLINTH_CLEARANCE
    if top < zmin + FOOTING_MIN_BAND:
        return None, None
    plan = MultiPoint(cw[:, :2]).convex_hull
    if plan.geom_type != "Polygon":
        return None, None
    held = _support_margin(cw[:, :2], com_w[:2])
    if held < FOOTING_MARGIN:
        return None, None
    ring = np.asarray(plan.exterior.coords, np.float64)[:-1]
    corners = np.vstack([np.c_[ring, np.full(len(ring), zmin)], np.c_[ring, np.full(len(ring), top)]])
    piece = hull_piece(place.body(corners))
    if piece is None:
        return None, None
    if others is not None and len(others) and inside_piece(others, (place.world(piece[0]), piece[1])).any():
        return None, {"plinth": "blocked: it would reach into a neighbour"}
    return piece, {
        "band_m": None,
        "plinth_m": [round(zmin, 4), round(top, 4)],
        "support_margin_after_m": round(held, 4),
        "why": "no band of its own mesh holds its centre of mass (with what rests on it): what it carries "
        "stands past its generated body (a body seen from one side), so a plinth under its whole plan, up to "
        "the lowest board it carries, is added",
    }
