"""Per-frame instance masks from a labelled mesh: ray-cast each camera (the project's Open3D renderer) and
keep a pixel's label only where the rendered surface agrees with the measured depth.

Used by the label-free front end (TSDF segments) and by the ScanNet importer (the labelled 3D mesh of a
scene's annotation). Unlabelled faces still occlude: they render as an id that maps to 0.

The label-free front end then fills what the ray cast leaves (``fill_from_surface``): a fused mesh has
holes where a thin panel was seen from both sides (a desk's side panel, a bookcase's side), and a ray
through one meets the wall behind, fails the depth test and leaves the pixel unlabelled.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from rescene_core.capture.depth_points import backproject
from rescene_core.records import Camera
from rescene_core.render.raycast import RayCaster, RenderMesh

UNLABELLED = 2**31 - 1
"""Render id of faces that belong to no instance (they occlude, and come out as 0)."""


def labelled_meshes(vertices: NDArray, faces: NDArray, face_labels: NDArray[np.int64]) -> list[RenderMesh]:
    """One ``RenderMesh`` per label (0 -> ``UNLABELLED``), each with the faces of that label."""
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    meshes = []
    for lab in np.unique(face_labels):
        sel = faces[face_labels == lab]
        used, inv = np.unique(sel.ravel(), return_inverse=True)
        meshes.append(
            RenderMesh.uniform(int(lab) if lab > 0 else UNLABELLED, vertices[used], inv.reshape(-1, 3), (0.5, 0.5, 0.5))
        )
    return meshes


def render_masks(
    caster: RayCaster,
    K: NDArray,
    world_from_cam: NDArray,
    width: int,
    height: int,
    depth: NDArray[np.float32] | None,
    abs_tolerance: float = 0.05,
    rel_tolerance: float = 0.05,
) -> tuple[NDArray[np.int32], dict[str, int]]:
    """Instance ids [T, H, W] of the caster's labelled meshes seen from each camera.

    depth: measured depth [T, H, W] (0 = invalid) or None. A labelled pixel whose rendered depth differs
    from the measured one by more than max(abs_tolerance, rel_tolerance * depth) becomes 0 (something
    the mesh does not hold is in front, or the mesh is wrong there). Pixels without a measurement keep
    the rendered label. Returns the masks and {"rejected_by_depth": pixels, "labelled": pixels}.
    """
    T = len(world_from_cam)
    out = np.zeros((T, height, width), np.int32)
    rejected = labelled = 0
    for t in range(T):
        hits = caster.cast_camera(Camera(np.asarray(K[t]), np.asarray(world_from_cam[t]), width, height))
        ids = np.where(hits.ids == UNLABELLED, 0, hits.ids).astype(np.int32)
        if depth is not None:
            d = np.asarray(depth[t])
            tol = np.maximum(abs_tolerance, rel_tolerance * d)
            bad = (ids > 0) & (d > 0) & (np.abs(hits.depth - d) > tol)
            rejected += int(bad.sum())
            ids[bad] = 0
        labelled += int((ids > 0).sum())
        out[t] = ids
    return out, {"rejected_by_depth": rejected, "labelled": labelled}


def fill_from_surface(
    masks: NDArray[np.int32],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    vertices: NDArray,
    vertex_labels: NDArray[np.int64],
    radius: float,
) -> int:
    """Pixels of ``masks`` [T, H, W] left 0 that have a measured depth take, in place, the label of the mesh
    vertex nearest their measured point (``vertices`` [v, 3] world frame, ``vertex_labels`` [v], 0: of no
    instance) when it lies within ``radius`` (m): the pixel lies on that surface. Returns how many pixels
    got a label."""
    tree = cKDTree(np.asarray(vertices, np.float64))
    filled = 0
    for t in range(len(masks)):
        pts, vs, us = backproject(depth[t], K[t], world_from_cam[t], masks[t] == 0)
        if len(pts) == 0:
            continue
        dist, idx = tree.query(pts, distance_upper_bound=radius, workers=-1)
        near = np.isfinite(dist)
        labels = vertex_labels[idx[near]]
        masks[t][vs[near], us[near]] = labels
        filled += int((labels > 0).sum())
    return filled
