"""Convex collision pieces and the primitives that cut them: an object's body frame (``Placement``), a piece
cut by a plane, a prism carved out of pieces, pieces clipped to their mesh's extent, inside tests, face
planes, the centre of mass. All in the body frame (metres): the asset frame scaled by the pose's scale,
rotated and translated by its rotation and translation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, TypeGuard

import numpy as np
import trimesh
from numpy.typing import NDArray
from shapely.geometry import MultiPoint
from shapely.geometry.polygon import orient

from rescene_core.geometry.completion import hull_mesh
from rescene_core.geometry.sim3 import scale_of
from rescene_core.records import Completion

Piece = tuple[NDArray[np.float64], NDArray[np.int64]]


BOARD_THICKNESS = 0.02
"""Thickness (m) of the board a support plane becomes, below the plane."""


CARVE_MARGIN = 0.002
"""A child's prism reaches this far (m) past its collider: faces that touch are not left overlapping."""


NEIGHBOUR_CLEARANCE = 0.002
"""A footing or a board under a child's foot reaching this far (m) into a neighbour's geometry reaches into it."""


MIN_PIECE_VOLUME = 1e-8
"""A cut piece smaller than this (m^3, a 1 cm x 1 cm x 0.1 mm sliver) is dropped."""


CLIP_DIRECTIONS = 24
"""Horizontal world directions (every 15 deg) along which pieces are cut to the mesh's extent."""


WORLD_UP = np.array([0.0, 0.0, 1.0])


class PlacedMesh(Protocol):
    """What the collider edits read of an object (``rescene_core.export.ExportObject`` is one): its id,
    its name in the exports, its mesh (asset frame: vertices float64 [v, 3], faces int64 [f, 3]), its final
    Sim(3) pose [4, 4] and the completions attachment gave it."""

    @property
    def instance(self) -> int: ...
    @property
    def node_name(self) -> str: ...
    @property
    def vertices(self) -> NDArray[np.float64]: ...
    @property
    def faces(self) -> NDArray[np.int64]: ...
    @property
    def world_from_asset(self) -> NDArray[np.float64]: ...
    @property
    def completions(self) -> tuple[Completion, ...]: ...


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


def placement(obj: PlacedMesh) -> Placement:
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


def hull_piece(points: NDArray) -> Piece | None:
    return hull_mesh(np.asarray(points, np.float64))


def slice_piece(piece: Piece, normal: NDArray, origin: NDArray) -> Piece | None:
    """The part of a convex piece on the side of the plane its normal points to, or None when empty."""
    v, f = piece
    d = (v - origin) @ normal
    if (d >= -1e-9).all():
        return piece
    if (d <= 1e-9).all():
        return None
    return hull_piece(np.vstack([v[d >= 0], edge_crossings(piece, d)]))


def edge_crossings(piece: Piece, d: NDArray) -> NDArray[np.float64]:
    """Points [k, 3] where the edges of a piece cross the plane of the signed distances ``d`` [v] of its
    vertices (from > 0 to <= 0)."""
    v, f = piece
    edges = trimesh.Trimesh(v, f, process=False).edges_unique
    da, db = d[edges[:, 0]], d[edges[:, 1]]
    cross = (da > 0) != (db > 0)
    a, b = v[edges[cross, 0]], v[edges[cross, 1]]
    t = da[cross] / (da[cross] - db[cross])
    return np.asarray(a + t[:, None] * (b - a), np.float64)


def footprint_ring(points_xy: NDArray, grow: float) -> NDArray[np.float64]:
    """Counter-clockwise corners [4, 2] of the smallest rotated rectangle around ``points_xy``, grown by
    ``grow`` (m) on every side."""

    rect = MultiPoint(np.asarray(points_xy, np.float64)).minimum_rotated_rectangle
    rect = rect.buffer(max(grow, 1e-4), join_style="mitre")
    return np.asarray(orient(rect, 1.0).exterior.coords, np.float64)[:-1]


def is_solid(piece: Piece | None) -> TypeGuard[Piece]:
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
            if rest is None:
                break
            outside = slice_piece(rest, normal, origin)
            if is_solid(outside):
                kept.append(outside)
            rest = slice_piece(rest, -normal, origin)
        low, high = np.array([0.0, 0.0, z_lo]), np.array([0.0, 0.0, z_hi])
        between = None if rest is None else slice_piece(rest, UP, low)
        if between is not None and np.isfinite(z_hi):
            between = slice_piece(between, DOWN, high)
        if rest is None or between is None or not is_solid(between):
            out.append(piece)  # it only touches the prism
            continue
        removed = max(removed, float(between[0][:, 2].max()) - z_lo)
        for part in (slice_piece(rest, DOWN, low), slice_piece(rest, UP, high) if np.isfinite(z_hi) else None):
            if is_solid(part):
                kept.append(part)
        out.extend(kept)
    return out, removed


def horizontal_directions(n: int) -> NDArray[np.float64]:
    """``n`` horizontal world unit vectors [n, 3], evenly spaced from +x."""
    angles = np.arange(n) * 2 * np.pi / n
    return np.c_[np.cos(angles), np.sin(angles), np.zeros_like(angles)]


def cut_seat(pieces: list[Piece], box_lo: NDArray, box_hi: NDArray, level: float) -> tuple[list[Piece], float]:
    """Pieces (world-oriented frame: z up) with everything above ``level`` inside the vertical column over
    the xy box [box_lo, box_hi] removed; returns the pieces and the depth removed (m)."""
    ring = np.array([box_lo, [box_hi[0], box_lo[1]], box_hi, [box_lo[0], box_hi[1]]], np.float64)
    return carve(pieces, ring, level, np.inf)


def clip_to_mesh(place: Placement, pieces: list[Piece], footprint_only: bool = False) -> tuple[list[Piece], float]:
    """Pieces cut to the mesh's extent along the asset axes, the world's up and down and ``CLIP_DIRECTIONS``
    horizontal world directions (a discrete oriented polytope of the mesh): a decomposition's piece never
    reaches past the mesh it approximates in those directions. ``footprint_only``: along the horizontal
    world directions only (a completion under or inside the mesh's footprint). Returns the pieces and the
    largest distance (m) a piece reached past them."""
    horizontal = horizontal_directions(CLIP_DIRECTIONS)
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
            rest = slice_piece(rest, normal, origin)
        if rest is not None:
            out.append(rest)
    return (out, reach) if out else (list(pieces), 0.0)


def inside_piece(points: NDArray, piece: Piece, tolerance: float = -NEIGHBOUR_CLEARANCE) -> NDArray[np.bool_]:
    """Which ``points`` [n, 3] lie inside the convex ``piece`` (same frame), its faces moved out by
    ``tolerance`` (m; negative: in)."""
    normals, offsets = face_planes(piece)
    return np.asarray(((np.asarray(points, np.float64) @ normals.T - offsets) <= tolerance).all(axis=1), np.bool_)


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
