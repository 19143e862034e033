"""Convex collision pieces of object meshes for the simulators (MuJoCo collides every mesh as its convex
hull, so a concave table needs several pieces).

Per mesh, exact pieces first: the mesh is split into connected components (by shared vertices); a
component whose volume is within ``CONVEX_TOLERANCE`` of its convex hull's is convex and its hull is a
piece as it is; a component whose faces are all axis-aligned (a union of boxes: the synthetic
furniture's shelves, legs and boards) is cut exactly into boxes on the grid of its vertex coordinates
(``box_pieces``). Their method is 'components'. The other components go to CoACD together, in one call;
when no component is exact, or one of the others is not a sound closed surface, the whole mesh goes to
CoACD. A small mesh (its largest extent under ``hull_below_m``, ExportConfig.hull_below_m: a cup, a jar, a
bowl) that is not exact gets its convex hull instead, method 'hull': CoACD spends tens of seconds on such
round, finely tessellated shapes (45-95 s each on an egocentric kitchen's cups, jars and bowls), and what
the hull fills at that size (a cup's inside, a handle's hole) is carved where a child stands in it
(rescene_core/colliders/seats.py). A sound closed mesh goes to CoACD (``coacd.run_coacd``, simplified
first when it has many faces, at most ``coacd_max_pieces`` pieces), run in a subprocess with a time limit
(rescene_core/colliders/coacd_worker.py), ``decomposition_workers`` at a time. When CoACD fails, times out
or the mesh is not a sound closed surface, the piece is the convex hull of the mesh, and when even that
is flat or degenerate, the mesh's oriented bounding box thickened to ``min_thickness``; each fallback is
written in the decomposition's ``notes`` (they go to ``scene/export_report.json``).

CoACD results are cached in the user cache (rescene_core/usercache.py: ``$RESCENE_CACHE_DIR/convex``,
size-capped, shared by every run and safe under concurrent writers) under the hash of the decomposed mesh's
vertices and faces, the CoACD settings and the code that answers (``coacd_code_version``: the coacd and
Open3D versions and the worker's source), so the same mesh (the same asset, a second run of a scene in a
fresh run directory, another scene of a split with the same furniture, the ground truth of a seed) is
decomposed once; the exact pieces take milliseconds and are not cached (an entry always holds CoACD's
answer for exactly the mesh it is keyed on). An entry that does not decode is decomposed and written again.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import io
import json
import subprocess
import sys
import tempfile
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.usercache import UserCache, cache_root, content_key

COACD_PARAMS_VERSION = 1
"""Bumped when the CoACD keywords change meaning, so old cache entries are not reused."""
WORKER_SCRIPT = Path(__file__).with_name("coacd_worker.py")
"""The CoACD subprocess (it imports only numpy and coacd)."""
CONVEX_TOLERANCE = 0.015
"""A component whose volume is at least (1 - this) of its convex hull's is taken as convex (a tessellated
cylinder or sphere is exactly convex; a box with a 1 cm notch in a 50 cm side is not)."""
MAX_GRID_CELLS = 1_000_000
"""Largest grid of an axis-aligned component cut into boxes; a finer one goes to CoACD."""
MAX_COVER_TESTS = 4_000_000
"""Largest (grid columns x horizontal triangles) tested at once (memory: ~8 bytes x 6 per test)."""
MIN_THICKNESS = 0.005
"""Smallest extent of a box fallback collider (m): a flat mesh (a picture's plane) still collides."""


@dataclass(frozen=True)
class DecompositionSettings:
    """How meshes are decomposed (from ExportConfig)."""

    threshold: float = 0.05
    max_pieces: int = 12
    max_faces: int = 2000
    timeout_s: float = 180.0
    workers: int = 2
    cache_dir: str | None = None
    hull_below_m: float | None = 0.15

    def coacd_params(self, watertight: bool) -> dict[str, object]:
        """Keywords of ``coacd.run_coacd``: a reduced tree search (the defaults cost tens of seconds per
        object), no manifold pre-processing for meshes that are already closed."""
        return {
            "threshold": self.threshold,
            "max_convex_hull": self.max_pieces,
            "preprocess_mode": "off" if watertight else "on",
            "resolution": 500,
            "mcts_iterations": 40,
            "mcts_max_depth": 2,
            "mcts_nodes": 10,
            "seed": 0,
        }


@dataclass(frozen=True)
class Decomposition:
    """Convex pieces of one mesh, in the mesh's frame: each (vertices float64 [n, 3], faces int64 [m, 3]),
        a closed convex hull. method: 'components' (exact pieces only), 'coacd' (CoACD on at least one
    component), 'hull' or 'box'. notes: every fallback and repair made."""

    pieces: tuple[tuple[NDArray[np.float64], NDArray[np.int64]], ...]
    method: str
    seconds: float
    cached: bool = False
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def volume(self) -> float:
        return float(sum(trimesh.Trimesh(v, f, process=False).volume for v, f in self.pieces))


CACHE_NAMESPACE = "convex"
"""The user cache's folder of decompositions."""


def default_cache_dir() -> Path:
    """``$RESCENE_CACHE_DIR/convex`` (or the user cache's default root, see rescene_core/usercache.py)."""
    return cache_root() / CACHE_NAMESPACE


def decomposition_cache(settings: DecompositionSettings) -> UserCache:
    """The cache of ``settings``: its ``cache_dir`` when set, else the user cache's ``convex`` folder."""
    return UserCache(CACHE_NAMESPACE, directory=settings.cache_dir)


@functools.cache
def coacd_code_version() -> dict[str, str]:
    """What a cached CoACD answer depends on besides the mesh and the keywords: the coacd and Open3D
    (the simplification before it) versions and the worker script's source."""

    def version(name: str) -> str:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return "absent"

    worker = hashlib.sha256(WORKER_SCRIPT.read_bytes()).hexdigest()[:16]
    return {"coacd": version("coacd"), "open3d": version("open3d"), "worker": worker}


def mesh_key(vertices: NDArray, faces: NDArray, params: dict[str, object]) -> str:
    """sha256 of the mesh (float64 vertices, int64 faces), the decomposition settings and the code version."""
    return content_key(
        np.ascontiguousarray(vertices, np.float64),
        np.ascontiguousarray(faces, np.int64),
        {**params, "version": COACD_PARAMS_VERSION},
        coacd_code_version(),
    )


def check_mesh(vertices: NDArray, faces: NDArray) -> list[str]:
    """Why a mesh cannot go to CoACD as it is (empty when it can): no faces, non-finite vertices, not
    closed, zero volume."""
    v, f = np.asarray(vertices, np.float64).reshape(-1, 3), np.asarray(faces, np.int64).reshape(-1, 3)
    if len(f) == 0:
        return ["mesh has no faces"]
    if len(v) < 4:
        return [f"mesh has {len(v)} vertices, too few to enclose a volume"]
    if not np.isfinite(v).all():
        return ["mesh has non-finite vertices"]
    if f.min() < 0 or f.max() >= len(v):
        return ["mesh faces index missing vertices"]
    mesh = trimesh.Trimesh(v, f, process=True)
    problems = []
    if not mesh.is_watertight:
        problems.append("mesh is not watertight")
    if abs(mesh.volume) < 1e-9:
        problems.append("mesh has zero volume")
    return problems


def hull_pieces(vertices: NDArray) -> tuple[tuple[tuple[NDArray, NDArray], ...], str, list[str]]:
    """The convex hull of the points, or their oriented box thickened to MIN_THICKNESS when the hull is
    flat or degenerate: (pieces, method, notes)."""
    points = np.asarray(vertices, np.float64).reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    if len(points) >= 4:
        try:
            hull = trimesh.convex.convex_hull(points)
            if hull.volume > 1e-9 and hull.is_watertight:
                return ((np.asarray(hull.vertices), np.asarray(hull.faces)),), "hull", []
        except Exception:  # qhull raises on flat or repeated points; the box below covers them
            pass
    if len(points) == 0:
        points = np.zeros((1, 3))
    to_box, extents = trimesh.bounds.oriented_bounds(points) if len(points) >= 3 else (np.eye(4), np.zeros(3))
    if len(points) < 3:
        to_box[:3, 3] = -points.mean(axis=0)
    box = trimesh.creation.box(extents=np.maximum(extents, MIN_THICKNESS), transform=np.linalg.inv(to_box))
    note = f"collider is a box: the mesh is flat or degenerate (extents {np.round(extents, 4).tolist()} m)"
    return ((np.asarray(box.vertices), np.asarray(box.faces)),), "box", [note]


def simplify(vertices: NDArray, faces: NDArray, max_faces: int) -> tuple[NDArray, NDArray, list[str]]:
    """Quadric decimation (Open3D) to at most ``max_faces`` faces; the mesh as it is when already smaller."""
    if len(faces) <= max_faces:
        return vertices, faces, []
    import open3d as o3d

    mesh = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.asarray(vertices, np.float64)), o3d.utility.Vector3iVector(np.asarray(faces))
    )
    small = mesh.simplify_quadric_decimation(target_number_of_triangles=max_faces)
    v, f = np.asarray(small.vertices), np.asarray(small.triangles, np.int64)
    return v, f, [f"simplified from {len(faces)} to {len(f)} faces before decomposition"]


def _run_coacd(vertices: NDArray, faces: NDArray, params: dict, timeout: float) -> list[tuple[NDArray, NDArray]]:
    with tempfile.TemporaryDirectory(prefix="rescene-coacd-") as tmp:
        src, dst = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        np.savez(src, vertices=vertices, faces=faces, params=json.dumps(params))
        done = subprocess.run(
            # run as an isolated script: importing the package would cost seconds per object
            [sys.executable, "-I", str(WORKER_SCRIPT), str(src), str(dst)],
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if done.returncode != 0 or not dst.exists():
            tail = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            raise RuntimeError(f"CoACD failed ({tail})")
        out = np.load(dst)
        vo, fo = out["vertex_offsets"], out["face_offsets"]
        return [
            (np.asarray(out["vertices"][vo[k] : vo[k + 1]]), np.asarray(out["faces"][fo[k] : fo[k + 1]]))
            for k in range(len(vo) - 1)
        ]


def _convex_pieces(raw: list[tuple[NDArray, NDArray]]) -> list[tuple[NDArray, NDArray]]:
    """Each CoACD piece as a closed convex hull; flat or empty pieces are dropped."""
    out = []
    for v, _ in raw:
        if len(v) < 4:
            continue
        try:
            hull = trimesh.convex.convex_hull(np.asarray(v, np.float64))
        except Exception:  # a flat piece: qhull cannot build it, and it has no volume to collide with
            continue
        if hull.volume > 1e-9:
            out.append((np.asarray(hull.vertices), np.asarray(hull.faces, np.int64)))
    return out


def _encode(dec: Decomposition) -> bytes:
    data = io.BytesIO()
    np.savez(
        data,
        vertices=np.concatenate([v for v, _ in dec.pieces]),
        faces=np.concatenate([f for _, f in dec.pieces]),
        vertex_offsets=np.concatenate([[0], np.cumsum([len(v) for v, _ in dec.pieces])]).astype(np.int64),
        face_offsets=np.concatenate([[0], np.cumsum([len(f) for _, f in dec.pieces])]).astype(np.int64),
        meta=json.dumps({"method": dec.method, "seconds": dec.seconds, "notes": list(dec.notes)}),
    )
    return data.getvalue()


def _decode(raw: bytes) -> Decomposition | None:
    try:
        data = np.load(io.BytesIO(raw))
        meta = json.loads(str(data["meta"]))
        vo, fo = data["vertex_offsets"], data["face_offsets"]
        pieces = tuple(
            (np.asarray(data["vertices"][vo[k] : vo[k + 1]]), np.asarray(data["faces"][fo[k] : fo[k + 1]]))
            for k in range(len(vo) - 1)
        )
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):  # a damaged entry: decomposed again
        return None
    return Decomposition(pieces, meta["method"], float(meta["seconds"]), True, tuple(meta["notes"]))


def components(vertices: NDArray, faces: NDArray) -> list[tuple[NDArray[np.float64], NDArray[np.int64]]]:
    """The connected components of a mesh (faces joined by shared vertices, duplicates merged first)."""
    mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), process=True)
    parts = mesh.split(only_watertight=False)
    if len(parts) <= 1:
        return [(np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64))]
    return [(np.asarray(p.vertices), np.asarray(p.faces, np.int64)) for p in parts]


def _grid_coords(values: NDArray) -> NDArray[np.float64]:
    c = np.unique(np.round(values, 6))  # float32 sources (manifold3d) put one plane within 1e-7 m
    return c[np.concatenate([[True], np.diff(c) > 1e-5])]


def box_pieces(vertices: NDArray, faces: NDArray) -> list[tuple[NDArray, NDArray]] | None:
    """Exact boxes of a closed mesh whose faces are all axis-aligned (a union of boxes), or None when
    it is not one (a slanted face, a grid over MAX_GRID_CELLS, boxes that do not add up to its volume).

    The mesh is cut on the grid of its vertex coordinates; a cell is inside when a vertical ray from its
    centre crosses the mesh's horizontal faces an odd number of times (centres never lie on a face's
    outline, which runs along grid lines); inside cells are merged greedily into boxes (x, then y, then z).
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    mesh = trimesh.Trimesh(v, f, process=False)
    normals = mesh.face_normals
    if not (np.abs(normals).max(axis=1) > 1.0 - 1e-6).all():
        return None
    coords = [_grid_coords(v[:, k]) for k in range(3)]
    if min(len(c) for c in coords) < 2 or np.prod([len(c) - 1 for c in coords]) > MAX_GRID_CELLS:
        return None
    cx, cy, cz = ((c[:-1] + c[1:]) / 2 for c in coords)
    flat = np.abs(normals[:, 2]) > 1.0 - 1e-6
    tri = v[f[flat]]  # [h, 3, 3] horizontal triangles
    if len(cx) * len(cy) * len(tri) > MAX_COVER_TESTS:
        return None
    levels = np.round(tri[:, 0, 2], 6)
    px, py = (a.ravel() for a in np.meshgrid(cx, cy, indexing="ij"))
    # 2D barycentric test of every column centre against every horizontal triangle: [columns, h]
    a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
    det = (b[:, 1] - c[:, 1]) * (a[:, 0] - c[:, 0]) + (c[:, 0] - b[:, 0]) * (a[:, 1] - c[:, 1])
    dx, dy = px[:, None] - c[None, :, 0], py[:, None] - c[None, :, 1]
    l1 = ((b[:, 1] - c[:, 1]) * dx + (c[:, 0] - b[:, 0]) * dy) / det
    l2 = ((c[:, 1] - a[:, 1]) * dx + (a[:, 0] - c[:, 0]) * dy) / det
    covers = (l1 >= -1e-9) & (l2 >= -1e-9) & (1.0 - l1 - l2 >= -1e-9)
    inside = np.zeros((len(cx), len(cy), len(cz)), bool)
    for col in np.flatnonzero(covers.any(axis=1)):
        above = np.unique(levels[covers[col]])  # two triangles of one face share a level: counted once
        crossings = len(above) - np.searchsorted(above, cz)
        inside[col // len(cy), col % len(cy)] = crossings % 2 == 1
    boxes: list[tuple[NDArray, NDArray]] = []
    left = inside.copy()
    for i, j, k in np.argwhere(inside):
        if not left[i, j, k]:
            continue
        i1 = i
        while i1 + 1 < left.shape[0] and left[i1 + 1, j, k]:
            i1 += 1
        j1 = j
        while j1 + 1 < left.shape[1] and left[i : i1 + 1, j1 + 1, k].all():
            j1 += 1
        k1 = k
        while k1 + 1 < left.shape[2] and left[i : i1 + 1, j : j1 + 1, k1 + 1].all():
            k1 += 1
        left[i : i1 + 1, j : j1 + 1, k : k1 + 1] = False
        lo = np.array([coords[0][i], coords[1][j], coords[2][k]])
        hi = np.array([coords[0][i1 + 1], coords[1][j1 + 1], coords[2][k1 + 1]])
        box = trimesh.creation.box(bounds=np.stack([lo, hi]))
        boxes.append((np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64)))
    total = sum(float(np.prod(bv.max(0) - bv.min(0))) for bv, _ in boxes)
    if not boxes or abs(total - abs(mesh.volume)) > 1e-3 * abs(mesh.volume) + 1e-9:
        return None
    return boxes


def exact_pieces(vertices: NDArray, faces: NDArray) -> list[tuple[NDArray, NDArray]] | None:
    """The convex pieces of one closed component without CoACD: its hull when it is convex (volume
    within CONVEX_TOLERANCE of the hull's), its boxes when it is a union of axis-aligned boxes; None
    otherwise."""
    mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), process=False)
    if not mesh.is_watertight or abs(mesh.volume) < 1e-9:
        return None
    try:
        hull = mesh.convex_hull
    except Exception:  # qhull fails on flat input; such a component has no volume anyway
        return None
    if abs(mesh.volume) >= (1.0 - CONVEX_TOLERANCE) * hull.volume:
        return [(np.asarray(hull.vertices, np.float64), np.asarray(hull.faces, np.int64))]
    return box_pieces(mesh.vertices, mesh.faces)


def _decompose_coacd(v: NDArray, f: NDArray, problems: list[str], settings: DecompositionSettings) -> Decomposition:
    """CoACD's pieces of one mesh (or its hull/box fallback), cached on the mesh and the settings."""
    start = time.perf_counter()
    params = settings.coacd_params(watertight=not problems)
    key = mesh_key(v, f, params)
    cache = decomposition_cache(settings)
    raw = cache.get(key, ".npz")
    if raw is not None:
        if (hit := _decode(raw)) is not None:
            return hit
        cache.discard(key, ".npz")
    notes: list[str] = []
    pieces: list[tuple[NDArray, NDArray]] = []
    timed_out = False
    if problems:
        notes.append(f"convex hull instead of CoACD: {'; '.join(problems)}")
    else:
        sv, sf, simplified = simplify(v, f, settings.max_faces)
        notes += simplified
        try:
            pieces = _convex_pieces(_run_coacd(sv, sf, params, settings.timeout_s))
            if not pieces:
                notes.append("convex hull instead of CoACD: it returned no solid piece")
        except subprocess.TimeoutExpired:
            timed_out = True
            notes.append(f"convex hull instead of CoACD: no result within {settings.timeout_s:g} s")
        except (RuntimeError, OSError, ValueError) as err:
            notes.append(f"convex hull instead of CoACD: {err}")
    method = "coacd"
    if not pieces:
        hull, method, more = hull_pieces(v)
        pieces, notes = list(hull), notes + more
    dec = Decomposition(tuple(pieces), method, round(time.perf_counter() - start, 3), False, tuple(notes))
    if not timed_out:  # a time-out depends on the machine's load: the next export tries again
        cache.put(key, ".npz", _encode(dec))  # a read-only cache only costs time
    return dec


def decompose(vertices: NDArray, faces: NDArray, settings: DecompositionSettings) -> Decomposition:
    """Convex pieces of one mesh (see the module doc); never raises for a bad mesh."""
    start = time.perf_counter()
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    problems = check_mesh(v, f)
    if problems:
        return _decompose_coacd(v, f, problems, settings)
    parts = components(v, f)
    exact: list[tuple[NDArray, NDArray]] = []
    rest: list[tuple[NDArray, NDArray]] = []
    for cv, cf in parts:
        found = exact_pieces(cv, cf)
        if found is None:
            rest.append((cv, cf))
        else:
            exact += found
    if not rest:
        note = f"exact pieces of {len(parts)} component(s), no CoACD"
        return Decomposition(tuple(exact), "components", round(time.perf_counter() - start, 3), False, (note,))
    size = float(np.ptp(v, axis=0).max())
    if settings.hull_below_m is not None and size < settings.hull_below_m:
        hull, method, notes = hull_pieces(v)
        note = f"convex hull, no CoACD: a small object ({size:.3f} m across, under {settings.hull_below_m:g} m)"
        return Decomposition(hull, method, round(time.perf_counter() - start, 3), False, (note, *notes))
    sound = all(not check_mesh(cv, cf) for cv, cf in rest)
    if not exact or not sound:  # CoACD on the mesh as given (its cache key unchanged), as one solid
        return _decompose_coacd(v, f, [], settings)
    rv = np.concatenate([cv for cv, _ in rest])
    offsets = np.cumsum([0] + [len(cv) for cv, _ in rest[:-1]])
    rf = np.concatenate([cf + off for (_, cf), off in zip(rest, offsets, strict=True)])
    done = _decompose_coacd(rv, rf, [], settings)  # one call: the piece cap holds for the whole object
    notes = [f"exact pieces of {len(parts) - len(rest)} of {len(parts)} components, CoACD on the rest"]
    return Decomposition(
        tuple(exact) + done.pieces,
        done.method,
        round(time.perf_counter() - start, 3),
        done.cached,
        tuple(notes) + done.notes,
    )


def decompose_all(
    meshes: dict[str, tuple[NDArray, NDArray]], settings: DecompositionSettings
) -> dict[str, Decomposition]:
    """Decompose several meshes (name -> (vertices, faces)), ``settings.workers`` CoACD processes at a time."""
    if not meshes:
        return {}
    with ThreadPoolExecutor(max_workers=max(1, settings.workers)) as pool:
        futures = {name: pool.submit(decompose, v, f, settings) for name, (v, f) in meshes.items()}
        return {name: fut.result() for name, fut in futures.items()}
