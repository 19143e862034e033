"""The weight-free ``lift`` backend: one view's masked depth, completed by symmetry, closed into a solid.

1. The mask (eroded by ``lift.mask_erosion`` pixels to drop mixed edge depths) and valid depth pixels
   are back-projected with the view's camera into the world; the depth noise inside the mask is
   measured from the same view (``depth_noise``).
2. Shape cues from the visible points alone (``analyse_shape``): a near-planar upright surface (a
   picture, TV, mirror, clock: a trimmed plane fit holds 90 % of the points within twice the depth
   noise) is flat; otherwise the Open3D normals of the vertical faces vote, area-weighted, for the
   object's rectangular orientation, and the face direction that faces the camera most is the mirror
   normal (round or unclear objects: the horizontal direction towards the camera).
3. Generator frame (random-free, view-dependent, as a single-view generator's is its own): origin at
   the centroid of the lifted points, z = world up, y = the mirror normal, x = y cross z. The object's
   yaw in this frame depends on the chosen view, so registration has to recover it.
4. Completion: a flat object becomes a thin slab behind its visible plane (its convex outline extruded
   by ``lift.slab_fraction`` of its size, at least ``lift.slab_min_m``). Any other object is mirrored
   about the vertical plane across y that makes its completed depth ``lift.depth_visible_factor``
   times the visible depth extent (1: the plane halves the visible extent, so a box seen from above
   or obliquely gets its true depth), at most ``lift.max_depth_ratio`` times its visible width.
5. Silhouette fill: on a grid of ``lift.resolution`` cells along the longest side, each (x, z) column
   is filled between the smallest and largest y of the points in it (the solid the front and the
   mirrored back enclose), then closed morphologically and meshed by marching cubes: watertight. Only
   the largest part is kept, parts within ``lift.join_cells`` cells of each other counting as one
   (chair legs and lamp stems one or two cells thin must not cut the object in pieces).

What it cannot see it cannot make: a close-up crop (mask touching the image border), a grazing view
or few depth pixels give a partial, worse asset, as a single-view generator's quality depends on its
view; an object seen only from its flat front (nothing reveals its depth) comes out too shallow. Its
metadata records the mask size, whether the mask touches the border, the lifted count, the depth noise,
the shape cues and the completion used.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from rescene_core.assets.base import GenerationFailed, GeneratorInput, GeneratorOutput
from rescene_core.config import AssetConfig, LiftConfig
from rescene_core.geometry import sim3
from rescene_core.records import Camera

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


@dataclass(frozen=True)
class ShapeCues:
    """What the visible points say about the object's shape (world frame).

    facing: unit horizontal [3] normal of the dominant camera-facing vertical face (the mirror normal),
    or the horizontal direction towards the camera when no face dominates. axis_strength: how strongly
    the visible vertical faces agree on one rectangular (90-degree periodic) orientation, in [0, 1].
    flat: the visible points lie near one upright plane (a picture, TV, mirror, clock). planarity: the
    the plane fit's 90 % residual over its flatness tolerance (<= 1: flat). method: 'faces', 'plane' or 'view'.
    """

    facing: NDArray[np.float64]
    axis_strength: float
    flat: bool
    planarity: float
    method: str

    def to_json(self) -> dict[str, Any]:
        return {
            "facing": [float(v) for v in self.facing],
            "axis_strength": float(self.axis_strength),
            "flat": bool(self.flat),
            "planarity": float(self.planarity),
            "method": self.method,
        }


def _horizontal_towards(points: NDArray[np.float64], camera_centre: NDArray[np.float64]) -> NDArray[np.float64]:
    to_cam = np.asarray(camera_centre, np.float64) - points.mean(axis=0)
    to_cam[2] = 0.0
    norm = float(np.linalg.norm(to_cam))
    return to_cam / norm if norm > 1e-9 else np.array([0.0, 1.0, 0.0])


def depth_noise(view: GeneratorInput, erosion: int) -> float:
    """Robust depth noise (m) inside the mask: 1.4826 MAD of the depth minus its 5x5 median, on the mask
    eroded by ``erosion`` pixels (surfaces are smooth at that scale; silhouettes are excluded)."""
    if view.depth is None:
        return 0.0
    mask = np.asarray(view.mask, bool)
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return 0.0
    r0, r1 = max(rows.min() - 3, 0), rows.max() + 4
    c0, c1 = max(cols.min() - 3, 0), cols.max() + 4
    depth = np.asarray(view.depth, np.float64)[r0:r1, c0:c1]
    inner = ndimage.binary_erosion(mask[r0:r1, c0:c1], iterations=erosion) & np.isfinite(depth) & (depth > 0)
    if inner.sum() < 10:
        return 0.0
    diff = (depth - ndimage.median_filter(depth, size=5))[inner]
    return float(1.4826 * np.median(np.abs(diff - np.median(diff))))


def _trimmed_plane(points: NDArray[np.float64], keep: float, rounds: int = 3):
    """Plane (centre [3], unit normal [3]) fitted by PCA to the ``keep`` fraction of points closest to
    it, refitted ``rounds`` times; and the absolute residuals [n] (m) of all points."""
    inliers = np.ones(len(points), bool)
    for _ in range(rounds):
        centre = points[inliers].mean(axis=0)
        _, vecs = np.linalg.eigh(np.cov((points[inliers] - centre).T))
        normal = vecs[:, 0]
        residual = np.abs((points - centre) @ normal)
        inliers = residual <= np.quantile(residual, keep)
    return centre, normal, vecs, residual


def footprint_yaw(points: NDArray[np.float64], percentile: float, steps: int = 90) -> tuple[float, float]:
    """Yaw (rad, in [0, pi/2)) of the upright rectangle that best explains the footprint of ``points``
    [n, 3] (world, m), and that rectangle's area (m^2): of the boxes around the footprint (extents from
    ``percentile`` to 100 minus it) in ``steps`` equal yaw steps over 90 degrees (1 degree by default;
    deterministic), the one whose sides the points lie nearest to on average. The visible surface of a
    rectangular object (its front strip, an L of two faces, a top seen from above) lies on or fills a
    rectangle aligned with the object's sides."""
    xy = points[:: max(1, len(points) // 20000), :2]
    xy = xy - xy.mean(axis=0)
    angles = 0.5 * np.pi * np.arange(steps) / steps
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    u = xy @ dirs.T  # [n, steps]: coordinate along each candidate axis
    v = xy @ np.stack([-dirs[:, 1], dirs[:, 0]], axis=1).T  # and across it
    lo_u, hi_u = np.percentile(u, [percentile, 100.0 - percentile], axis=0)
    lo_v, hi_v = np.percentile(v, [percentile, 100.0 - percentile], axis=0)
    area = (hi_u - lo_u) * (hi_v - lo_v)
    # the visible points of a box lie on its sides: the mean distance to the nearest side of the box is
    # smallest in the box's own axes (the smallest area alone ties an L of two faces with its hypotenuse)
    edge = np.minimum(np.minimum(u - lo_u, hi_u - u), np.minimum(v - lo_v, hi_v - v))
    best = int(np.argmin(np.abs(edge).mean(axis=0)))
    return float(angles[best]), float(area[best])


def _box_area(points: NDArray[np.float64], axis: NDArray[np.float64], percentile: float) -> float:
    """Area (m^2) of the robust upright box around the footprint of ``points`` [n, 3] aligned with the
    horizontal unit ``axis`` [3]."""
    xy = points[:: max(1, len(points) // 20000), :2]
    across = np.array([-axis[1], axis[0]])
    u, v = xy @ axis[:2], xy @ across
    (lo_u, lo_v), (hi_u, hi_v) = np.percentile(np.stack([u, v], axis=1), [percentile, 100.0 - percentile], axis=0)
    return float((hi_u - lo_u) * (hi_v - lo_v))


def analyse_shape(points: NDArray[np.float64], camera: Camera, noise: float, cfg: LiftConfig) -> ShapeCues:
    """Dominant facing direction and flatness of the visible surface ``points`` [n, 3] (world, m).

    Flat: a plane fitted to the ``lift.flat_inlier_fraction`` closest points holds 90 % of all points
    within max(``lift.flat_noise_factor`` x ``noise`` (the depth noise, m), ``lift.flat_min_tolerance``
    x the in-plane extent), and its normal lies within ``lift.flat_max_tilt_deg`` of horizontal (upright
    panels: pictures, TVs, mirrors, clocks). Otherwise the normals (Open3D, ``lift.normal_neighbours``
    nearest points, oriented to the camera) vote, weighted by the surface area each pixel covers
    (depth^2 / f^2 / |cos incidence|, the cosine floored at ``lift.min_incidence_cos``) times the
    normal's squared horizontal length, for one orientation modulo 90 degrees (rectangular furniture);
    the facing direction is the one of the four that collects the most facing area. Below
    ``lift.min_axis_strength`` agreement the direction towards the camera is used (round objects).
    """
    import open3d as o3d

    towards = _horizontal_towards(points, camera.center)
    centre, normal, axes, residual = _trimmed_plane(points, cfg.flat_inlier_fraction)
    in_plane = (points - centre) @ axes[:, 1:]
    extent = float(np.ptp(in_plane, axis=0).max())
    spread = float(np.quantile(residual, 0.9))
    tolerance = max(cfg.flat_noise_factor * noise, cfg.flat_min_tolerance * extent)
    planarity = spread / tolerance if tolerance > 0 else float("inf")
    tilt = float(np.degrees(np.arcsin(min(1.0, abs(float(normal[2]))))))
    if planarity <= 1.0 and tilt <= cfg.flat_max_tilt_deg:
        facing = normal.copy()
        facing[2] = 0.0
        facing /= np.linalg.norm(facing)
        if facing @ towards < 0:
            facing = -facing
        return ShapeCues(facing, 1.0, True, planarity, "plane")

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(int(cfg.normal_neighbours)))
    cloud.orient_normals_towards_camera_location(np.asarray(camera.center, np.float64))
    normals = np.asarray(cloud.normals)
    rays = points - np.asarray(camera.center, np.float64)
    dist = np.linalg.norm(rays, axis=1)
    incidence = np.abs(np.einsum("ij,ij->i", normals, rays)) / np.maximum(dist, 1e-9)
    cam_z = sim3.apply(sim3.inverse(camera.world_from_cam), points)[:, 2]
    focal = float(np.sqrt(camera.K[0, 0] * camera.K[1, 1]))
    area = (cam_z / focal) ** 2 / np.maximum(incidence, cfg.min_incidence_cos)
    horizontal = np.linalg.norm(normals[:, :2], axis=1)
    weight = area * horizontal**2
    angle = np.arctan2(normals[:, 1], normals[:, 0])
    vote = np.sum(weight * np.exp(4j * angle))
    total = float(weight.sum())
    strength = float(abs(vote) / total) if total > 0 else 0.0
    base, area = footprint_yaw(points, 0.0)
    candidates = base + 0.5 * np.pi * np.arange(4)
    dirs = np.stack([np.cos(candidates), np.sin(candidates), np.zeros(4)], axis=1)
    if strength < cfg.min_axis_strength:
        # no face dominates: a round object (its footprint box is about as tight at any yaw) keeps the
        # direction to the camera; a rectangular one seen through noise or legs has a footprint box
        # clearly tighter than the view-aligned one, and takes its axis nearest the camera
        view_area = _box_area(points, towards, 0.0)
        if area > (1.0 - cfg.min_axis_strength) * view_area:
            return ShapeCues(towards, strength, False, planarity, "view")
        return ShapeCues(dirs[int(np.argmax(dirs @ towards))], strength, False, planarity, "footprint")
    facing_area = (weight[:, None] * np.maximum(normals[:, :2] @ dirs[:, :2].T, 0.0)).sum(axis=0)
    return ShapeCues(dirs[int(np.argmax(facing_area))], strength, False, planarity, "faces")


def generator_frame(
    points: NDArray[np.float64], camera_centre: NDArray[np.float64], facing: NDArray[np.float64] | None = None
) -> sim3.Matrix4:
    """world_from_generator: origin at the centroid, z up, y = ``facing`` (a horizontal unit vector: the
    object's dominant camera-facing normal) or, when None, horizontally towards the camera."""
    centre = points.mean(axis=0)
    y = _horizontal_towards(points, camera_centre) if facing is None else np.asarray(facing, np.float64)
    x = np.cross(y, UP)
    rot = np.stack([x, y, UP], axis=1)
    return sim3.sim3_from_parts(1.0, rot, centre)


def complete_by_mirror(local: NDArray[np.float64], cfg: LiftConfig) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """The visible points [n, 3] (generator frame: y = the facing normal) and their mirror image.

    The mirror plane y = p is placed so that the completed depth along y is
    D = ``lift.depth_visible_factor`` x the visible depth extent, bounded by ``lift.max_depth_ratio``
    x the visible width along x (objects are rarely much deeper than wide) and never below the visible
    depth: p = y_front - D / 2. Extents are robust (``lift.extent_percentile`` to 100 minus it).
    """
    q = cfg.extent_percentile
    (x_lo, y_lo), (x_hi, y_hi) = np.percentile(local[:, :2], [q, 100.0 - q], axis=0)
    visible_depth = float(y_hi - y_lo)
    width = float(x_hi - x_lo)
    depth = min(cfg.depth_visible_factor * visible_depth, cfg.max_depth_ratio * width)
    depth = max(depth, visible_depth)
    plane = float(y_hi) - 0.5 * depth
    mirrored = local.copy()
    mirrored[:, 1] = 2.0 * plane - local[:, 1]
    info = {
        "kind": "mirror",
        "plane_y": plane,
        "visible_depth_m": visible_depth,
        "visible_width_m": width,
        "depth_m": depth,
    }
    return np.concatenate([local, mirrored]), info


def flat_slab(
    local: NDArray[np.float64], cfg: LiftConfig
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """A thin upright slab for near-planar objects: the convex outline of the points [n, 3] (generator
    frame, y = the plane normal towards the camera) in the x-z plane, extruded backwards from the
    visible plane by T = max(``lift.slab_min_m``, ``lift.slab_fraction`` x the outline's longest side).
    Returns vertices [v, 3], faces [f, 3] (watertight) and the completion record."""
    import trimesh
    from shapely.geometry import MultiPoint

    outline = MultiPoint(local[:, [0, 2]]).convex_hull
    if outline.geom_type != "Polygon" or outline.area <= 0:
        raise GenerationFailed("the flat object's outline is degenerate")
    outline = outline.simplify(0.002 * float(np.sqrt(outline.area)))
    minx, minz, maxx, maxz = outline.bounds
    extent = float(max(maxx - minx, maxz - minz))
    thickness = max(cfg.slab_min_m, cfg.slab_fraction * extent)
    front = float(np.median(local[:, 1]))
    slab = trimesh.creation.extrude_polygon(outline, thickness)
    # extrusion frame (u, v, w) -> generator (x = u, y = front - w, z = v): a proper rotation
    vertices = np.asarray(slab.vertices)
    vertices = np.stack([vertices[:, 0], front - vertices[:, 2], vertices[:, 1]], axis=1)
    info = {"kind": "flat_slab", "thickness_m": thickness, "extent_m": extent, "plane_y": front}
    return vertices, np.asarray(slab.faces, dtype=np.int64), info


def _remove_outliers(points: NDArray[np.float64]) -> NDArray[np.float64]:
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    _, keep = cloud.remove_statistical_outlier(nb_neighbors=16, std_ratio=2.5)
    return points[np.asarray(keep, dtype=np.int64)] if len(keep) >= 0.5 * len(points) else points


def solid_from_points(
    points: NDArray[np.float64], resolution: int, join: int = 0
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Watertight mesh (vertices [v, 3], faces [f, 3], same frame as ``points``) of the column-filled solid.

    Only the largest connected part is kept, where parts less than ``join`` grid cells apart count as
    connected (the cells between them stay empty): thin legs, stems and depth dropouts split one object
    into parts a cell or two apart, while stray depth pixels form islands farther off."""
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
    if not grid.any():
        raise GenerationFailed("no solid left after filling")
    # keep the largest connected part: stray depth pixels become no floating islands
    joined = ndimage.binary_dilation(grid, iterations=join) if join > 0 else grid
    labels, count = ndimage.label(joined)
    if count > 1:
        sizes = ndimage.sum(grid, labels, index=np.arange(1, count + 1))
        grid = grid & (labels == (1 + int(np.argmax(sizes))))
    mesh = matrix_to_marching_cubes(grid, pitch=pitch)
    vertices = np.asarray(mesh.vertices) + lo - 2 * pitch
    # marching cubes puts the surface half a cell outside the outermost occupied cell centres, so each
    # side grows by up to a cell (13 % of a bookshelf's depth at 40 cells): fit the mesh's box to the
    # kept points' box, axis by axis (axes the points do not span keep the mesh's extent)
    kept = points[grid[ijk[:, 0] + 2, ijk[:, 1] + 2, ijk[:, 2] + 2]]
    if len(kept):
        v_lo, v_hi = vertices.min(axis=0), vertices.max(axis=0)
        p_lo, p_hi = kept.min(axis=0), kept.max(axis=0)
        span = p_hi - p_lo
        fit = span > pitch
        scale = np.where(fit, span / np.maximum(v_hi - v_lo, 1e-12), 1.0)
        start = np.where(fit, p_lo, 0.5 * (p_lo + p_hi) - 0.5 * (v_hi - v_lo))
        vertices = start + (vertices - v_lo) * scale
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
        cfg = self.config.lift
        pixels = int(np.count_nonzero(view.mask))
        if pixels < cfg.min_pixels:
            raise GenerationFailed(f"mask has {pixels} pixels; the lift backend needs >= {cfg.min_pixels}")
        world = lift_points(view, cfg.mask_erosion)
        if len(world) < cfg.min_pixels:
            raise GenerationFailed(f"only {len(world)} masked pixels have valid depth (< {cfg.min_pixels})")
        world = _remove_outliers(world)
        noise = depth_noise(view, cfg.noise_erosion)
        shape = analyse_shape(world, view.camera, noise, cfg)
        world_from_generator = generator_frame(world, view.camera.center, shape.facing)
        local = sim3.apply(sim3.inverse(world_from_generator), world)
        completion: dict[str, Any]
        if shape.flat and cfg.mirror:
            vertices, faces, completion = flat_slab(local, cfg)
        else:
            completed, completion = complete_by_mirror(local, cfg) if cfg.mirror else (local, {"kind": "none"})
            vertices, faces = solid_from_points(completed, cfg.resolution, cfg.join_cells)
            vertices, faces = _decimate(vertices, faces, self.config.target_faces)
        mask = np.asarray(view.mask, bool)
        touches = bool(mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())
        metadata: dict[str, Any] = {
            "frame": int(view.frame),
            "label": view.label,
            "mask_pixels": pixels,
            "lifted_points": int(len(world)),
            "mask_touches_border": touches,
            "mirror_completion": bool(cfg.mirror),
            "completion": completion,
            "shape": shape.to_json(),
            "depth_noise_m": noise,
            "resolution": int(cfg.resolution),
            "weights": "none (geometric backend)",
            # the canonicalisation this backend used; kept for inspection, not handed to registration
            "world_from_generator": world_from_generator.tolist(),
        }
        return GeneratorOutput(vertices, faces, metadata)
