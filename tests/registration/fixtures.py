"""Registration fixtures: composite meshes in a canonical frame, assets, and partial noisy scans of them."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from rescene_core.geometry import sim3
from rescene_core.records import Asset, InstanceId, InstancePoints


def chair_mesh() -> trimesh.Trimesh:
    """An asymmetric chair (metres, canonical frame: origin at the bottom centre, z up, front +y)."""
    parts = [trimesh.creation.box((0.5, 0.5, 0.06), trimesh.transformations.translation_matrix((0, 0, 0.45)))]
    for x in (-0.21, 0.21):
        for y in (-0.21, 0.21):
            parts.append(
                trimesh.creation.box((0.05, 0.05, 0.42), trimesh.transformations.translation_matrix((x, y, 0.21)))
            )
    parts.append(trimesh.creation.box((0.5, 0.05, 0.5), trimesh.transformations.translation_matrix((0, -0.225, 0.73))))
    parts.append(
        trimesh.creation.box((0.05, 0.35, 0.2), trimesh.transformations.translation_matrix((0.225, 0.0, 0.58)))
    )
    return trimesh.util.concatenate(parts)


def table_mesh() -> trimesh.Trimesh:
    parts = [trimesh.creation.box((1.2, 0.7, 0.04), trimesh.transformations.translation_matrix((0, 0, 0.73)))]
    for x in (-0.55, 0.55):
        for y in (-0.3, 0.3):
            parts.append(
                trimesh.creation.cylinder(
                    0.03, 0.71, transform=trimesh.transformations.translation_matrix((x, y, 0.355))
                )
            )
    return trimesh.util.concatenate(parts)


def unit_box_asset(
    mesh: trimesh.Trimesh, asset_from_object: np.ndarray | None = None, instance: int = 7
) -> tuple[Asset, np.ndarray]:
    """Normalise a mesh (after an optional Sim(3)) into a centred unit box; returns (asset, asset_from_object)."""
    m = np.eye(4) if asset_from_object is None else asset_from_object
    v = sim3.apply(m, mesh.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    norm = sim3.sim3_from_parts(1.0 / float((hi - lo).max()), np.eye(3), -0.5 * (lo + hi) / float((hi - lo).max()))
    full = sim3.compose(norm, m)
    return Asset(InstanceId(instance), sim3.apply(full, mesh.vertices), np.asarray(mesh.faces, np.int64), "gt"), full


def random_world_from_object(rng: np.random.Generator, max_tilt_deg: float = 0.0) -> np.ndarray:
    yaw = rng.uniform(-np.pi, np.pi)
    axis = np.array([*rng.normal(size=2), 0.0])
    axis /= np.linalg.norm(axis)
    tilt = Rotation.from_rotvec(axis * np.deg2rad(rng.uniform(0, max_tilt_deg)))
    rot = (tilt * Rotation.from_euler("z", yaw)).as_matrix()
    return sim3.sim3_from_parts(1.0, rot, rng.uniform(-3, 3, size=3))


def scan(
    mesh: trimesh.Trimesh,
    world_from_object: np.ndarray,
    rng: np.random.Generator,
    n: int = 4000,
    noise: float = 0.005,
    partial: bool = True,
    instance: int = 7,
) -> InstancePoints:
    """Points on the posed mesh; partial=True keeps only the half facing a viewpoint and drops the underside."""
    pts, face = trimesh.sample.sample_surface(mesh, n * 3, seed=int(rng.integers(1 << 30)))
    normals = mesh.face_normals[face]
    keep = np.ones(len(pts), bool)
    if partial:
        view = np.array([np.cos(0.6), np.sin(0.6), 0.0])  # a viewpoint in front-right, at object height
        keep = (normals @ view > -0.05) & (normals[:, 2] > -0.5)
    pts = pts[keep][:n]
    world = sim3.apply(world_from_object, pts) + rng.normal(scale=noise, size=pts.shape)
    return InstancePoints(InstanceId(instance), world.astype(np.float32), np.zeros((len(world), 3), np.uint8))
