"""Meshes and convex solids of the ``Completion`` records attachment adds to generated meshes.

A support plane is a horizontal polygon: as a surface it is two-sided triangles (what contact metrics
read), as a solid it is the polygon extruded downwards by a board thickness (what a simulator collides
with). A base is already a solid: the convex hull of its points. A cut removes the part of the mesh behind
its plane (``cut_mesh``, capped so a closed mesh stays closed); cuts apply before anything is added. Everything is in the object's asset
frame; ``world_from_asset`` only tells which way is down and how long a metre is there.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from rescene_core.geometry.sim3 import scale_of
from rescene_core.records import Completion, CompletionKind

WORLD_UP = np.array([0.0, 0.0, 1.0])
CUT_CLEARANCE = 1e-6
"""Least distance (asset units) a cut plane keeps from every vertex. trimesh's slicing takes a vertex within
1e-8 of the plane as lying on it, and an edge from such a vertex to one just past 1e-8 is intersected far
outside the mesh: a cut at a mesh's own side face (its vertex ring on the plane to within rounding) grew a
counter's footprint 0.45 m. Moving the plane a few micrometres keeps every vertex clearly on one side."""


def _fan(count: int, offset: int) -> NDArray[np.int64]:
    return np.array([[0, j, j + 1] for j in range(1, count - 1)], np.int64).reshape(-1, 3) + offset


def hull_mesh(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]] | None:
    """Convex hull of ``points`` [k, 3] as (vertices [v, 3], outward faces [f, 3]); None when flat or degenerate."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    if len(pts) < 4:
        return None
    try:
        hull = ConvexHull(pts)
    except QhullError:
        return None
    used = np.unique(hull.simplices)
    remap = np.full(len(pts), -1, np.int64)
    remap[used] = np.arange(len(used))
    faces = remap[hull.simplices]
    verts = pts[used]
    # Qhull's simplices are not consistently oriented: turn each face's normal away from the centroid
    tri = verts[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inward = np.einsum("ij,ij->i", normal, tri[:, 0] - verts.mean(axis=0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return verts, faces


def completion_surface(completion: Completion) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Triangles of a completion for contact tests: a support plane as two-sided fan triangles, a base as
    its convex hull (its points as two-sided fans when they are flat)."""
    pts = np.asarray(completion.points_asset, np.float64).reshape(-1, 3)
    if completion.kind is CompletionKind.BASE:
        hull = hull_mesh(pts)
        if hull is not None:
            return hull
    fan = _fan(len(pts), 0)
    return pts, np.vstack([fan, fan[:, ::-1]])


def clear_of_vertices(
    vertices: NDArray[np.float64], origin: NDArray[np.float64], unit: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``origin`` [3] moved along the plane's unit normal ``unit`` [3] (towards the side kept, by the fewest
    steps of 2 ``CUT_CLEARANCE``) until no vertex of ``vertices`` [v, 3] lies within ``CUT_CLEARANCE`` of the
    plane; ``origin`` itself when no such step up to 32 clears them."""
    dots = (np.asarray(vertices, np.float64) - origin) @ unit
    for step in range(33):
        shift = 2.0 * CUT_CLEARANCE * step
        if not np.any(np.abs(dots - shift) < CUT_CLEARANCE):
            return origin + shift * unit
    return origin


def cut_mesh(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], cuts: Iterable[Completion]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The mesh (vertices [v, 3], faces [f, 3], asset frame) with the part behind each cut plane removed,
    the cut capped when the mesh is closed; a cut that would leave nothing is not applied."""

    mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), process=False)
    for cut in cuts:
        origin, tip = np.asarray(cut.points_asset, np.float64).reshape(2, 3)
        normal = tip - origin
        if not np.linalg.norm(normal) > 0:
            continue
        normal = normal / np.linalg.norm(normal)
        origin = clear_of_vertices(np.asarray(mesh.vertices), origin, normal)
        kept = trimesh.intersections.slice_mesh_plane(mesh, normal, origin, cap=mesh.is_watertight)
        if kept is not None and len(kept.faces):
            mesh = kept
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def completed_mesh(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], completions: Iterable[Completion]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """An asset-frame mesh (vertices [v, 3], faces [f, 3]): cut at the completions' cut planes, then with the
    other completions' triangles appended."""
    completions = list(completions)
    vertices, faces = cut_mesh(vertices, faces, [c for c in completions if c.kind is CompletionKind.CUT])
    verts, tris = [np.asarray(vertices, np.float64)], [np.asarray(faces, np.int64)]
    count = len(verts[0])
    for completion in completions:
        if completion.kind is CompletionKind.CUT:
            continue
        v, f = completion_surface(completion)
        verts.append(v)
        tris.append(f + count)
        count += len(v)
    return np.vstack(verts), np.vstack(tris)


def completion_solid(
    completion: Completion, world_from_asset: NDArray[np.float64], board_thickness_m: float
) -> NDArray[np.float64]:
    """Asset-frame vertices [k, 3] of the convex solid a simulator collides with: a support plane's polygon
    and its copy ``board_thickness_m`` (m) lower in the world, or a base's points."""
    pts = np.asarray(completion.points_asset, np.float64).reshape(-1, 3)
    if completion.kind is CompletionKind.BASE:
        return pts
    m = np.asarray(world_from_asset, np.float64)
    down_asset = -(m[:3, :3].T @ WORLD_UP) / scale_of(m)  # a world metre downwards, in asset units
    return np.vstack([pts, pts + board_thickness_m * down_asset / scale_of(m)])
