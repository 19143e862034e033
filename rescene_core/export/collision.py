"""Convex collision pieces of object meshes for the simulators (MuJoCo collides every mesh as its convex
hull, so a concave table needs several pieces).

Per mesh: a sound closed mesh goes to CoACD (``coacd.run_coacd``, simplified first when it has many
faces, at most ``coacd_max_pieces`` pieces), run in a subprocess with a time limit
(rescene_core/export/coacd_worker.py), ``decomposition_workers`` at a time. When CoACD fails, times out
or the mesh is not a sound closed surface, the piece is the convex hull of the mesh, and when even that
is flat or degenerate, the mesh's oriented bounding box thickened to ``min_thickness``; each fallback is
written in the decomposition's ``notes`` (they go to ``scene/export_report.json``).

Results are cached on disk under the hash of the mesh's vertices and faces and the CoACD settings, so
the same mesh (the same asset, a re-run, the ground truth of a seed) is decomposed once.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import NDArray

COACD_PARAMS_VERSION = 1
"""Bumped when the CoACD keywords change meaning, so old cache entries are not reused."""
WORKER_SCRIPT = Path(__file__).with_name("coacd_worker.py")
"""The CoACD subprocess (it imports only numpy and coacd)."""
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
    a closed convex hull. method: 'coacd', 'hull' or 'box'. notes: every fallback and repair made."""

    pieces: tuple[tuple[NDArray[np.float64], NDArray[np.int64]], ...]
    method: str
    seconds: float
    cached: bool = False
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def volume(self) -> float:
        return float(sum(trimesh.Trimesh(v, f, process=False).volume for v, f in self.pieces))


def default_cache_dir() -> Path:
    """``$RESCENE_CACHE_DIR/convex`` or ``~/.cache/rescene/convex``."""
    root = os.environ.get("RESCENE_CACHE_DIR") or Path.home() / ".cache" / "rescene"
    return Path(root) / "convex"


def mesh_key(vertices: NDArray, faces: NDArray, params: dict[str, object]) -> str:
    """sha256 of the mesh (float64 vertices, int64 faces) and the decomposition settings."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(vertices, np.float64).tobytes())
    h.update(np.ascontiguousarray(faces, np.int64).tobytes())
    h.update(json.dumps({**params, "version": COACD_PARAMS_VERSION}, sort_keys=True).encode())
    return h.hexdigest()


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


def _save(path: Path, dec: Decomposition) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(
        tmp,
        vertices=np.concatenate([v for v, _ in dec.pieces]),
        faces=np.concatenate([f for _, f in dec.pieces]),
        vertex_offsets=np.concatenate([[0], np.cumsum([len(v) for v, _ in dec.pieces])]).astype(np.int64),
        face_offsets=np.concatenate([[0], np.cumsum([len(f) for _, f in dec.pieces])]).astype(np.int64),
        meta=json.dumps({"method": dec.method, "seconds": dec.seconds, "notes": list(dec.notes)}),
    )
    os.replace(tmp, path)


def _load(path: Path) -> Decomposition | None:
    try:
        data = np.load(path)
        meta = json.loads(str(data["meta"]))
        vo, fo = data["vertex_offsets"], data["face_offsets"]
        pieces = tuple(
            (np.asarray(data["vertices"][vo[k] : vo[k + 1]]), np.asarray(data["faces"][fo[k] : fo[k + 1]]))
            for k in range(len(vo) - 1)
        )
    except (OSError, ValueError, KeyError):  # a damaged cache entry is decomposed again
        return None
    return Decomposition(pieces, meta["method"], float(meta["seconds"]), True, tuple(meta["notes"]))


def decompose(vertices: NDArray, faces: NDArray, settings: DecompositionSettings) -> Decomposition:
    """Convex pieces of one mesh (see the module doc); never raises for a bad mesh."""
    start = time.perf_counter()
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    problems = check_mesh(v, f)
    params = settings.coacd_params(watertight=not problems)
    key = mesh_key(v, f, params)
    cache = Path(settings.cache_dir) if settings.cache_dir else default_cache_dir()
    entry = cache / key[:2] / f"{key}.npz"
    if entry.exists() and (hit := _load(entry)) is not None:
        return hit
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
        try:
            _save(entry, dec)
        except OSError:  # a read-only cache only costs time
            pass
    return dec


def decompose_all(
    meshes: dict[str, tuple[NDArray, NDArray]], settings: DecompositionSettings
) -> dict[str, Decomposition]:
    """Decompose several meshes (name -> (vertices, faces)), ``settings.workers`` CoACD processes at a time."""
    if not meshes:
        return {}
    with ThreadPoolExecutor(max_workers=max(1, settings.workers)) as pool:
        futures = {name: pool.submit(decompose, v, f, settings) for name, (v, f) in meshes.items()}
        return {name: fut.result() for name, fut in futures.items()}
