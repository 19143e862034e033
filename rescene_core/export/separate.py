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
object occupies changes hands. When no plane does, the objects themselves overlap (a layout fault): their
pieces are left as they are and the report says by how much.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.export.completions import Piece, Placement, _slice, inside_piece

MIN_DEPTH = 0.002
"""Pieces overlapping less than this (m) are left as they are (MuJoCo resolves millimetres quietly)."""
INSIDE_TOLERANCE = 0.005
"""An object's surface point within this distance (m) outside one of its pieces counts as inside it."""
SEPARATE_TOLERANCE = 0.005
"""Two objects whose geometry overlaps by at most this much (m) along the cut's normal are still separated
(the cut runs through the middle of the overlap)."""
PASSES = 3
"""Rounds of detection and cutting (a cut piece can still overlap another piece of the neighbour)."""
SAMPLES = 4000
"""Surface samples per mesh (plus its vertices and face centres)."""
HORIZONTAL_DIRECTIONS = 24


def _directions() -> NDArray[np.float64]:
    angles = np.arange(HORIZONTAL_DIRECTIONS) * 2 * np.pi / HORIZONTAL_DIRECTIONS
    return np.vstack([[[0, 0, 1.0], [0, 0, -1.0]], np.c_[np.cos(angles), np.sin(angles), np.zeros_like(angles)]])


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


def overlaps(world_pieces: dict[str, list[Piece]], min_depth: float = MIN_DEPTH) -> list[dict[str, Any]]:
    """Pairs of pieces of different objects overlapping by more than ``min_depth`` (MuJoCo's narrow phase on
    the pieces as convex meshes): ``{"a", "ka", "b", "kb", "depth", "normal" (from a's piece to b's),
    "point"}``, the deepest contact of each pair."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    names: dict[str, tuple[str, int]] = {}
    for b, (node, pieces) in enumerate(world_pieces.items()):
        body = spec.worldbody.add_body(name=f"b{b}", mass=1.0, inertia=[1.0, 1.0, 1.0])
        body.add_freejoint()
        for k, (v, f) in enumerate(pieces):
            mesh = spec.add_mesh(name=f"m{b}_{k}")
            mesh.uservert = np.asarray(v, np.float64).ravel().tolist()
            mesh.userface = np.asarray(f, np.int64).ravel().tolist()
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
            geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{b}_{k}", name=f"g{b}_{k}")
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
        (a, ka), (b, kb) = names[model.geom(c.geom1).name], names[model.geom(c.geom2).name]
        if a == b:
            continue
        normal = np.asarray(c.frame[:3], np.float64).copy()
        if (b, kb) < (a, ka):
            (a, ka), (b, kb), normal = (b, kb), (a, ka), -normal
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


def separate(
    places: dict[str, Placement],
    pieces: dict[str, list[Piece]],
    evidence: dict[str, tuple[NDArray, NDArray]],
    related: set[frozenset[str]],
) -> dict[str, list[dict[str, Any]]]:
    """Cut apart the pieces (body frame, changed in place) of neighbours that overlap where neither object
    is (see the module doc). ``evidence``: node -> world points of its mesh and of its completions (``evidence_points``);
    ``related``: pairs of nodes one of which rests on the other (left to the seats). Returns node -> report
    entries."""
    world = {n: [(places[n].world(v), f) for v, f in ps] for n, ps in pieces.items()}
    entries: dict[str, dict[str, dict[str, Any]]] = {n: {} for n in pieces}
    for _ in range(PASSES):
        found = [o for o in overlaps(world) if frozenset((o["a"], o["b"])) not in related]
        if not found:
            break
        cut_any = False
        for o in sorted(found, key=lambda o: -o["depth"]):
            a, b, ka, kb = o["a"], o["b"], o["ka"], o["kb"]
            pa, pb = world[a][ka], world[b][kb]
            if pa is None or pb is None:
                continue
            (ma, ca), (mb, cb) = evidence[a], evidence[b]
            ma, mb = ma[_inside(ma, pa, INSIDE_TOLERANCE)], mb[_inside(mb, pb, INSIDE_TOLERANCE)]
            ca, cb = ca[_inside(ca, pa, INSIDE_TOLERANCE)], cb[_inside(cb, pb, INSIDE_TOLERANCE)]
            d, c, gap = separating_plane(np.vstack([ma, ca]), np.vstack([mb, cb]), o["normal"], o["point"])
            for node, other in ((a, b), (b, a)):
                entry = entries[node].setdefault(other, {"neighbour": other, "depth_m": 0.0, "pieces_cut": 0})
                entry["depth_m"] = round(max(entry["depth_m"], o["depth"]), 4)
            if gap < -SEPARATE_TOLERANCE:
                mesh_gap = separating_plane(ma, mb, o["normal"], o["point"])[2]
                for node, other in ((a, b), (b, a)):
                    e = entries[node][other]
                    e["objects_overlap_m"] = round(max(e.get("objects_overlap_m", 0.0), -gap), 4)
                    e["meshes_overlap_m"] = round(max(e.get("meshes_overlap_m", 0.0), -mesh_gap, 0.0), 4)
                continue
            world[a][ka] = _slice(pa, -d, c * d)
            world[b][kb] = _slice(pb, d, c * d)
            cut_any = True
            for node, other in ((a, b), (b, a)):
                entries[node][other]["pieces_cut"] += 1
        world = {n: [p for p in ps if p is not None] for n, ps in world.items()}
        if not cut_any:
            break
    for n in pieces:
        pieces[n] = [(places[n].body(v), f) for v, f in world[n]]
    out: dict[str, list[dict[str, Any]]] = {}
    for n, by_other in entries.items():
        rows = []
        for e in by_other.values():
            if e.get("objects_overlap_m") is not None:
                what = "their meshes" if e["meshes_overlap_m"] > SEPARATE_TOLERANCE else "their completions (a base)"
                e["why"] = (
                    f"{what} overlap by {e['objects_overlap_m']:.3f} m: no plane separates them (a layout fault), "
                    "left as they are"
                )
            else:
                e["why"] = "their convex pieces overlapped where neither object is: cut apart by a plane between them"
            rows.append(e)
        if rows:
            out[n] = sorted(rows, key=lambda e: e["neighbour"])
    return out
