"""Collision pieces of two neighbours that overlap where neither object is: cut apart by a plane.

A convex piece covers more than its part of the mesh (CoACD fills the concavities it spans, a hollow shell's
panels are its mesh's box, a footing is a hull), so two objects that stand close (a chair tucked under a
table, a lamp beside a nightstand) can start with their pieces overlapping by centimetres where their meshes
do not meet, and the simulator throws them apart at t = 0.

For every pair of pieces of two objects, neither resting on the other (directly or through others), that
overlap by more than ``MIN_DEPTH`` at the start (found by MuJoCo's own collision detection on the pieces),
the objects' geometry inside each piece is looked at: its mesh's surface and the completions attachment gave
it (boards, bases), sampled. When a plane separates the two (the contact normal first, else the world's up or
down or one of 24 horizontal directions), both pieces are cut at that plane, midway between the two objects'
geometry, each keeping its own side (a convex piece cut by a plane stays convex): only space that neither
object occupies changes hands. When no plane does, one piece may fill a concavity the other object stands
in (a bed's piece spanning the notch beside its headboard where the nightstand's top is): the piece is carved
(``carve``: split by the sides of a vertical prism, the part inside cut at its bottom and top, all parts
convex) where the other object's geometry inside it is (the smallest rotated rectangle around it, from its
lowest to its highest point, grown by ``CARVE_MARGIN``), when none of its own object's mesh lies in that prism
(moved in by ``SEPARATE_TOLERANCE``): a completion or a piece yields to the other's geometry where its own mesh
is not. When neither piece can be carved, one piece gives way to the other (``subtract``): it is split by the
other piece's face planes and keeps only its convex parts outside it (outside its oriented box when the other
has more than ``MAX_SUBTRACT_PLANES`` face planes). The piece that gives way is the one whose own object has
the smaller share of its surface inside the other's piece (a generated table's solid block around a tucked-in
chair gives way; the chair, mostly inside the block, keeps its pieces). Two colliders that start inside each
other are thrown apart by the simulator, whatever the cause; the report still says how deep the objects'
meshes and completions overlap (a layout fault when they do), so the subtraction hides nothing the layout
got wrong.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import shapely
import trimesh
from numpy.typing import NDArray
from shapely.geometry import Polygon

from rescene_core.colliders.pieces import (
    CARVE_MARGIN,
    Piece,
    Placement,
    carve,
    face_planes,
    footprint_ring,
    horizontal_directions,
    inside_piece,
    is_solid,
    slice_piece,
)

MIN_DEPTH = 0.0005
"""Pieces overlapping less than this (m) are left as they are. MuJoCo resolves millimetres quietly, but a
position-based engine (Newton's XPBD) turns a t = 0 overlap into velocity, depth / time step: 1.5 mm at 1 ms
is 1.5 m/s."""
INSIDE_TOLERANCE = 0.005
"""An object's surface point within this distance (m) outside one of its pieces counts as inside it."""
SEPARATE_TOLERANCE = 0.005
"""Two objects whose geometry overlaps by at most this much (m) along the cut's normal are still separated
(the cut runs through the middle of the overlap)."""
PASSES = 6
"""Rounds of detection and cutting (a cut piece can still overlap another piece of the neighbour; a piece
that gave way in one round meets its other neighbours' pieces in the next)."""
SAMPLES = 4000
"""Surface samples per mesh (plus its vertices and face centres)."""
HORIZONTAL_DIRECTIONS = 24
MAX_SUBTRACT_PLANES = 12
"""A piece with more distinct face planes than this is subtracted as its oriented box (at most 6 parts)."""


def _directions() -> NDArray[np.float64]:
    return np.vstack([[[0, 0, 1.0], [0, 0, -1.0]], horizontal_directions(HORIZONTAL_DIRECTIONS)])


def evidence_points(place: Placement, extra: Iterable[Piece] = ()) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World points of an object's geometry: its mesh's vertices, face centres and surface samples [n, 3],
    and surface samples of ``extra`` (body-frame pieces of its completions) [m, 3]."""
    mesh = trimesh.Trimesh(place.world(place.vertices), place.faces, process=False)
    parts = [mesh.vertices, mesh.triangles_center]
    if mesh.area > 0:
        parts.append(mesh.sample(SAMPLES, seed=0))
    added = [np.zeros((0, 3))]
    for v, f in extra:
        piece = trimesh.Trimesh(place.world(v), f, process=False)
        added += [piece.vertices, piece.sample(200, seed=0)]
    return np.vstack(parts), np.vstack(added)


def _inside(points: NDArray, piece: Piece, tolerance: float) -> NDArray[np.bool_]:
    return inside_piece(points, piece, tolerance)


def overlaps(world_pieces: Mapping[str, Sequence[Piece | None]], min_depth: float = MIN_DEPTH) -> list[dict[str, Any]]:
    """Pairs of pieces of different objects overlapping by more than ``min_depth`` (MuJoCo's narrow phase on
    the pieces as convex meshes): ``{"a", "ka", "b", "kb", "depth", "normal" (from a's piece to b's),
    "point"}``, the deepest contact of each pair."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    names: dict[str, tuple[str, int]] = {}
    for bi, (node, pieces) in enumerate(world_pieces.items()):
        body = spec.worldbody.add_body(name=f"b{bi}", mass=1.0, inertia=[1.0, 1.0, 1.0])
        body.add_freejoint()
        for k, piece in enumerate(pieces):
            if piece is None:  # a piece that gave way entirely (its index kept for the others)
                continue
            v, f = piece
            mesh = spec.add_mesh(name=f"m{bi}_{k}")
            mesh.uservert = np.asarray(v, np.float64).ravel().tolist()
            mesh.userface = np.asarray(f, np.int64).ravel().tolist()
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{bi}_{k}", name=f"g{bi}_{k}")
            names[geom.name] = (node, k)
    if not names:
        return []
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    deepest: dict[tuple[str, int, str, int], dict[str, Any]] = {}
    for c in data.contact[: data.ncon]:
        depth = -float(c.dist)
        if depth <= min_depth:
            continue
        first, second = names[model.geom(c.geom1).name], names[model.geom(c.geom2).name]
        if first[0] == second[0]:
            continue
        normal = np.asarray(c.frame[:3], np.float64).copy()
        if second < first:
            first, second, normal = second, first, -normal
        (a, ka), (b, kb) = first, second
        key = (a, ka, b, kb)
        if key not in deepest or depth > deepest[key]["depth"]:
            deepest[key] = {"a": a, "ka": ka, "b": b, "kb": kb, "depth": depth, "normal": normal, "point": c.pos.copy()}
    return list(deepest.values())


def separating_plane(
    inside_a: NDArray, inside_b: NDArray, normal: NDArray, point: NDArray
) -> tuple[NDArray[np.float64], float, float]:
    """The plane (unit normal d, offset c: a keeps d.x <= c, b keeps d.x >= c) that best separates an
    object's points ``inside_a`` from its neighbour's ``inside_b``, and the gap (m) between them along d
    (negative: they overlap by that much). ``normal``: the contact normal from a to b, tried first;
    ``point``: the contact point, where the cut runs when neither object has geometry there."""
    normal = np.asarray(normal, np.float64) / max(float(np.linalg.norm(normal)), 1e-12)
    candidates = np.vstack([normal[None], _directions()])
    best: tuple[NDArray[np.float64], float, float] | None = None
    for d in candidates:
        top = float((inside_a @ d).max()) if len(inside_a) else -np.inf
        low = float((inside_b @ d).min()) if len(inside_b) else np.inf
        gap = low - top
        if np.isinf(gap):
            c = float(point @ d) if np.isinf(top) and np.isinf(low) else (top if np.isfinite(top) else low)
        else:
            c = 0.5 * (top + low)
        if gap >= -SEPARATE_TOLERANCE:
            return d, c, gap  # the first that works: the contact normal when it does
        if best is None or gap > best[2]:
            best = (d, c, gap)
    assert best is not None
    return best


def _depth_in_mesh(points: NDArray, mesh: trimesh.Trimesh) -> float:
    """How deep (m) the deepest of ``points`` lies inside the closed ``mesh`` (0 when none is, or the mesh is
    not closed): Open3D's signed distance (ray-parity inside test, C++)."""
    lo, hi = mesh.bounds
    points = points[((points >= lo) & (points <= hi)).all(axis=1)]  # only where it can be
    if len(points) == 0 or not mesh.is_watertight:
        return 0.0
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    # Open3D's stubs take no numpy array in o3d.core.Tensor (the bindings do)
    vertices = o3d.core.Tensor(np.asarray(mesh.vertices, np.float32))  # type: ignore[call-overload]
    scene.add_triangles(vertices, o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))  # type: ignore[call-overload]
    signed = scene.compute_signed_distance(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()  # type: ignore[call-overload]
    return max(0.0, float(-signed.min()))


def _depth_in_piece(points: NDArray, piece: Piece) -> float:
    """How deep (m) the deepest of ``points`` lies inside the convex ``piece`` (0 when none is)."""
    if len(points) == 0:
        return 0.0
    normals, offsets = face_planes(piece)
    return max(0.0, float((offsets - points @ normals.T).min(axis=1).max()))


def carve_where_other_is(piece: Piece, other_inside: NDArray, own: NDArray) -> list[Piece] | None:
    """The parts of the world ``piece`` left after carving the vertical prism around the neighbour's geometry
    inside it (``other_inside`` [n, 3]; see the module doc), or None when the prism holds some of the piece's
    own object's mesh (``own`` [m, 3], its surface points) or the carve removes nothing."""

    if len(other_inside) < 3:
        return None
    ring = footprint_ring(other_inside[:, :2], CARVE_MARGIN)
    z_lo, z_hi = float(other_inside[:, 2].min()) - CARVE_MARGIN, float(other_inside[:, 2].max()) + CARVE_MARGIN
    inner = Polygon(ring).buffer(-SEPARATE_TOLERANCE, join_style="mitre")
    if inner.is_empty:
        return None
    z = own[:, 2]
    near = own[(z > z_lo + SEPARATE_TOLERANCE) & (z < z_hi - SEPARATE_TOLERANCE)]
    if shapely.contains_xy(inner, near[:, 0], near[:, 1]).any():
        return None
    parts, removed = carve([piece], ring, z_lo, z_hi)
    return parts if removed > 0.0 else None


def _distinct_planes(piece: Piece) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A convex piece's distinct face planes: outward unit normals [k, 3] and offsets [k]."""
    normals, offsets = face_planes(piece)
    if len(normals) == 0:
        return normals, offsets
    _, first = np.unique(np.round(np.c_[normals, offsets], 4), axis=0, return_index=True)
    first = np.sort(first)
    return normals[first], offsets[first]


def subtract(piece: Piece, other: Piece) -> list[Piece]:
    """The convex parts [k <= planes] of the world ``piece`` outside the convex world ``other`` (outside its
    oriented bounding box when it has more than ``MAX_SUBTRACT_PLANES`` face planes): for each face plane of
    the other in turn, the part of what is left beyond it is kept and the rest goes on to the next plane."""
    normals, offsets = _distinct_planes(other)
    if len(normals) > MAX_SUBTRACT_PLANES:
        box = trimesh.Trimesh(*other, process=False).bounding_box_oriented
        normals, offsets = _distinct_planes((np.asarray(box.vertices), np.asarray(box.faces)))
    parts: list[Piece] = []
    rest: Piece | None = piece
    for normal, offset in zip(normals, offsets, strict=True):
        origin = normal * offset
        if rest is None:
            break
        beyond = slice_piece(rest, normal, origin)
        if beyond is not None and is_solid(beyond):
            parts.append(beyond)
        rest = slice_piece(rest, -normal, origin)
        if rest is None:
            break
    return parts


def _share_inside(points: NDArray, piece: Piece) -> float:
    """The share of an object's surface points [n, 3] inside a convex piece."""
    return float(_inside(points, piece, INSIDE_TOLERANCE).mean()) if len(points) else 0.0


def overlap_depths(
    places: dict[str, Placement],
    evidence: dict[str, tuple[NDArray, NDArray]],
    completions: dict[str, list[Piece]],
    a: str,
    b: str,
) -> tuple[float, float]:
    """How deep (m) two objects overlap: their meshes (each one's surface points inside the other's closed
    mesh), and anything involving a completion (a mesh's or completion's points inside the other's
    completion pieces, a completion's points inside the other's mesh)."""
    meshes = {n: trimesh.Trimesh(places[n].world(places[n].vertices), places[n].faces, process=True) for n in (a, b)}
    meshes_depth = max(_depth_in_mesh(evidence[a][0], meshes[b]), _depth_in_mesh(evidence[b][0], meshes[a]))
    with_completions = 0.0
    for x, y in ((a, b), (b, a)):
        mesh_x, added_x = evidence[x]
        with_completions = max(with_completions, _depth_in_mesh(added_x, meshes[y]))
        for v, f in completions.get(y, []):
            piece = (places[y].world(v), f)
            with_completions = max(with_completions, _depth_in_piece(np.vstack([mesh_x, added_x]), piece))
    return meshes_depth, with_completions


def separate(
    places: dict[str, Placement],
    pieces: dict[str, list[Piece]],
    evidence: dict[str, tuple[NDArray, NDArray]],
    related: set[frozenset[str]],
    completions: dict[str, list[Piece]] | None = None,
) -> dict[str, list[dict[str, Any]]]:
    """Cut apart the pieces (body frame, changed in place) of neighbours that overlap where neither object
    is (see the module doc). ``evidence``: node -> world points of its mesh and of its completions
    (``evidence_points``); ``related``: pairs of nodes one of which rests on the other (left to the seats);
    ``completions``: node -> body-frame pieces of its completions (for the report's overlap depths).
    Returns node -> report entries."""
    world: dict[str, list[Piece | None]] = {n: [(places[n].world(v), f) for v, f in ps] for n, ps in pieces.items()}
    entries: dict[str, dict[str, dict[str, Any]]] = {n: {} for n in pieces}
    for _ in range(PASSES):
        found = [o for o in overlaps(world) if frozenset((o["a"], o["b"])) not in related]
        if not found:
            break
        cut_any = False
        subtracted: set[tuple[str, int]] = set()  # pieces split this round: their other contacts wait a round
        for o in sorted(found, key=lambda o: -o["depth"]):
            a, b, ka, kb = o["a"], o["b"], o["ka"], o["kb"]
            pa, pb = world[a][ka], world[b][kb]
            if pa is None or pb is None or (a, ka) in subtracted or (b, kb) in subtracted:
                continue
            (ma, ca), (mb, cb) = evidence[a], evidence[b]
            ma, mb = ma[_inside(ma, pa, INSIDE_TOLERANCE)], mb[_inside(mb, pb, INSIDE_TOLERANCE)]
            ca, cb = ca[_inside(ca, pa, INSIDE_TOLERANCE)], cb[_inside(cb, pb, INSIDE_TOLERANCE)]
            d, c, gap = separating_plane(np.vstack([ma, ca]), np.vstack([mb, cb]), o["normal"], o["point"])
            for node, other in ((a, b), (b, a)):
                entry = entries[node].setdefault(other, {"neighbour": other, "depth_m": 0.0, "pieces_cut": 0})
                entry["depth_m"] = round(max(entry["depth_m"], o["depth"]), 4)
            if gap < -SEPARATE_TOLERANCE:
                carved = False
                for node, k, piece, other_in in ((a, ka, pa, np.vstack([mb, cb])), (b, kb, pb, np.vstack([ma, ca]))):
                    parts = carve_where_other_is(piece, other_in, evidence[node][0])
                    if parts is None:
                        continue
                    world[node][k] = parts[0] if parts else None
                    world[node].extend(parts[1:])
                    entries[node][b if node == a else a]["pieces_carved"] = (
                        entries[node][b if node == a else a].get("pieces_carved", 0) + 1
                    )
                    carved = cut_any = True
                if not carved:
                    for node, other in ((a, b), (b, a)):
                        e = entries[node][other]
                        e["objects_overlap_m"] = round(max(e.get("objects_overlap_m", 0.0), -gap), 4)
                    # the piece whose object has less of itself inside the other's piece gives way
                    share_a, share_b = _share_inside(evidence[a][0], pb), _share_inside(evidence[b][0], pa)
                    node, k, piece, other_piece, other = (
                        (a, ka, pa, pb, b) if share_a <= share_b else (b, kb, pb, pa, a)
                    )
                    parts = subtract(piece, other_piece)
                    world[node][k] = parts[0] if parts else None
                    world[node].extend(parts[1:])
                    e = entries[node][other]
                    e["pieces_subtracted"] = e.get("pieces_subtracted", 0) + 1
                    subtracted.add((node, k))
                    cut_any = True
                continue
            world[a][ka] = slice_piece(pa, -d, c * d)
            world[b][kb] = slice_piece(pb, d, c * d)
            cut_any = True
            for node, other in ((a, b), (b, a)):
                entries[node][other]["pieces_cut"] += 1
        world = {n: [p for p in ps if p is not None] for n, ps in world.items()}
        if not cut_any:
            break
    for n in pieces:
        pieces[n] = [(places[n].body(p[0]), p[1]) for p in world[n] if p is not None]
    out: dict[str, list[dict[str, Any]]] = {}
    depths: dict[frozenset[str], tuple[float, float]] = {}
    for n, by_other in entries.items():
        rows = []
        for other, e in by_other.items():
            if e.get("objects_overlap_m") is None and e.get("pieces_carved"):
                e["why"] = (
                    "a convex piece of one filled a concavity the other stands in: carved where the other's geometry is"
                )
                rows.append(e)
                continue
            if e.get("objects_overlap_m") is not None:
                key = frozenset((n, other))
                if key not in depths:
                    depths[key] = overlap_depths(places, evidence, completions or {}, n, other)
                meshes_depth, with_completions = depths[key]
                e["meshes_overlap_m"] = round(meshes_depth, 4)
                e["completions_overlap_m"] = round(with_completions, 4)
                if meshes_depth > SEPARATE_TOLERANCE:
                    what = f"their meshes overlap by {meshes_depth:.3f} m"
                elif with_completions > SEPARATE_TOLERANCE:
                    what = f"a completion (a base, a board) of one reaches {with_completions:.3f} m into the other"
                else:
                    what = (
                        "their meshes and completions do not overlap, but one stands in a concavity of the other "
                        "that no plane cuts off"
                    )
                fault = "a layout fault" if max(meshes_depth, with_completions) > SEPARATE_TOLERANCE else "not cut"
                gave_way = (
                    "; its piece gave way to the other's (convex subtraction)"
                    if e.get("pieces_subtracted")
                    else "; the other's piece gave way to its (convex subtraction)"
                )
                e["why"] = f"{what}: no plane separates them ({fault}){gave_way}"
            else:
                e["why"] = "their convex pieces overlapped where neither object is: cut apart by a plane between them"
            rows.append(e)
        if rows:
            out[n] = sorted(rows, key=lambda e: e["neighbour"])
    return out
