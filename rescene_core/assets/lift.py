"""The weight-free ``lift`` backend: one view's masked depth, completed by symmetry, closed into a solid.

1. The mask (eroded by ``lift_mask_erosion`` pixels to drop mixed edge depths) and valid depth pixels
   are back-projected with the view's camera into the world.
2. Generator frame (random-free, view-dependent, as a single-view generator's is its own): origin at
   the centroid of the lifted points, z = world up, y = the horizontal direction from the object to
   the camera, x = y cross z. The object's yaw in this frame depends on the chosen view, so
   registration has to recover it.
3. Completion by the object's likely symmetry: the points are mirrored about the vertical plane
   through their centroid perpendicular to the horizontal view direction (y -> 2 mean(y) - y), which
   puts a back behind the seen front.
4. Silhouette fill: on a grid of ``lift_resolution`` cells along the longest side, each (x, z) column
   is filled between the smallest and largest y of the points in it (the solid the front and the
   mirrored back enclose), then closed morphologically and meshed by marching cubes: watertight.

What it cannot see it cannot make: a close-up crop (mask touching the image border), a grazing view
or few depth pixels give a partial, worse asset, as a single-view generator's quality depends on its
view. Its metadata records the mask size, whether the mask touches the border, and the lifted count.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from rescene_core.assets.base import GenerationFailed, GeneratorInput, GeneratorOutput
from rescene_core.config import AssetConfig
from rescene_core.geometry import sim3

UP = np.array([0.0, 0.0, 1.0])


def lift_points(view: GeneratorInput, erosion: int) -> NDArray[np.float64]:
    """World points [n, 3] (m) of the view's masked, valid depth pixels."""
    if view.depth is None:
        raise GenerationFailed("the lift backend needs depth; this capture has none (use the sam3d backend)")
    mask = np.asarray(view.mask, bool)
    if erosion > 0:
        eroded = ndimage.binary_erosion(mask, iterations=erosion)
        mask = eroded if eroded.sum() >= 0.25 * mask.sum() else mask
    depth = np.asarray(view.depth, np.float64)
    valid = mask & np.isfinite(depth) & (depth > 0)
    v, u = np.nonzero(valid)
    z = depth[v, u]
    K = view.camera.K
    x = (u + 0.5 - K[0, 2]) / K[0, 0] * z
    y = (v + 0.5 - K[1, 2]) / K[1, 1] * z
    cam = np.stack([x, y, z], axis=1)
    return sim3.apply(view.camera.world_from_cam, cam)


def generator_frame(points: NDArray[np.float64], camera_centre: NDArray[np.float64]) -> sim3.Matrix4:
    """world_from_generator: origin at the centroid, z up, y horizontally towards the camera."""
    centre = points.mean(axis=0)
    to_cam = camera_centre - centre
    to_cam[2] = 0.0
    norm = float(np.linalg.norm(to_cam))
    y = to_cam / norm if norm > 1e-9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(y, UP)
    rot = np.stack([x, y, UP], axis=1)
    return sim3.sim3_from_parts(1.0, rot, centre)


def _remove_outliers(points: NDArray[np.float64]) -> NDArray[np.float64]:
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    _, keep = cloud.remove_statistical_outlier(nb_neighbors=16, std_ratio=2.5)
    return points[np.asarray(keep, dtype=np.int64)] if len(keep) >= 0.5 * len(points) else points


def solid_from_points(points: NDArray[np.float64], resolution: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Watertight mesh (vertices [v, 3], faces [f, 3], same frame as ``points``) of the column-filled solid."""
    from trimesh.voxel.ops import matrix_to_marching_cubes

    lo, hi = points.min(axis=0), points.max(axis=0)
    pitch = float((hi - lo).max()) / resolution
    if not pitch > 0:
        raise GenerationFailed("lifted points collapse to a single point")
    dims = np.maximum(np.ceil((hi - lo) / pitch).astype(int) + 1, 1)
    ijk = np.minimum(((points - lo) / pitch).astype(int), dims - 1)
    # per (x, z) column: the smallest and largest occupied y cell
    flat = ijk[:, 0] * dims[2] + ijk[:, 2]
    ymin = np.full(dims[0] * dims[2], np.iinfo(np.int64).max)
    ymax = np.full(dims[0] * dims[2], -1)
    np.minimum.at(ymin, flat, ijk[:, 1])
    np.maximum.at(ymax, flat, ijk[:, 1])
    ys = np.arange(dims[1])
    filled = (ys[None, :] >= ymin[:, None]) & (ys[None, :] <= ymax[:, None])  # [x*z, y]
    grid = filled.reshape(dims[0], dims[2], dims[1]).transpose(0, 2, 1)
    grid = ndimage.binary_closing(np.pad(grid, 2), iterations=1)
    grid = ndimage.binary_fill_holes(grid)
    labels, count = ndimage.label(grid)
    if count == 0:
        raise GenerationFailed("no solid left after filling")
    if count > 1:  # keep the largest connected part: stray depth pixels become no floating islands
        sizes = ndimage.sum(grid, labels, index=np.arange(1, count + 1))
        grid = labels == (1 + int(np.argmax(sizes)))
    mesh = matrix_to_marching_cubes(grid, pitch=pitch)
    vertices = np.asarray(mesh.vertices) + lo - 2 * pitch
    return vertices, np.asarray(mesh.faces, dtype=np.int64)


def _decimate(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], target_faces: int
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Quadric decimation (Open3D) to ``target_faces``, kept only if the result stays watertight."""
    if len(faces) <= target_faces:
        return vertices, faces
    import open3d as o3d
    import trimesh

    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    simple = mesh.simplify_quadric_decimation(int(target_faces))
    v, f = np.asarray(simple.vertices), np.asarray(simple.triangles, dtype=np.int64)
    check = trimesh.Trimesh(v, f, process=True)
    if len(f) and check.is_watertight and check.is_winding_consistent:
        return np.asarray(check.vertices), np.asarray(check.faces, dtype=np.int64)
    return vertices, faces


class LiftBackend:
    """Weight-free single-view generator (see the module docstring)."""

    name = "lift"

    def __init__(self, config: AssetConfig):
        self.config = config

    def generate(self, view: GeneratorInput) -> GeneratorOutput:
        cfg = self.config
        pixels = int(np.count_nonzero(view.mask))
        if pixels < cfg.lift_min_pixels:
            raise GenerationFailed(f"mask has {pixels} pixels; the lift backend needs >= {cfg.lift_min_pixels}")
        world = lift_points(view, cfg.lift_mask_erosion)
        if len(world) < cfg.lift_min_pixels:
            raise GenerationFailed(f"only {len(world)} masked pixels have valid depth (< {cfg.lift_min_pixels})")
        world = _remove_outliers(world)
        world_from_generator = generator_frame(world, view.camera.center)
        local = sim3.apply(sim3.inverse(world_from_generator), world)
        mirrored = local.copy()
        mirrored[:, 1] = 2.0 * local[:, 1].mean() - local[:, 1]
        completed = np.concatenate([local, mirrored]) if cfg.lift_mirror else local
        vertices, faces = solid_from_points(completed, cfg.lift_resolution)
        vertices, faces = _decimate(vertices, faces, cfg.target_faces)
        mask = np.asarray(view.mask, bool)
        touches = bool(mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())
        metadata: dict[str, Any] = {
            "frame": int(view.frame),
            "label": view.label,
            "mask_pixels": pixels,
            "lifted_points": int(len(world)),
            "mask_touches_border": touches,
            "mirror_completion": bool(cfg.lift_mirror),
            "resolution": int(cfg.lift_resolution),
            "weights": "none (geometric backend)",
            # the canonicalisation this backend used; kept for inspection, not handed to registration
            "world_from_generator": world_from_generator.tolist(),
        }
        return GeneratorOutput(vertices, faces, metadata)
