"""CPU ray casting of triangle meshes with Open3D's ``RaycastingScene``.

One ray per pixel centre, from a ``Camera`` (OpenCV axes). Ray directions are scaled so that their
camera-z component is 1: the hit parameter ``t`` is then the depth along the camera z axis (metres).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from rescene_core.records import Camera


class Texture:
    """Procedural texture codes, one per face (``RenderMesh.face_textures``)."""

    PLAIN = 0
    WOOD = 1
    FABRIC = 2
    PLANKS = 3
    PAINTING = 4
    SCREEN = 5
    FOLIAGE = 6
    PAINT = 7  # matte wall paint: faint large-scale mottling


@dataclass(frozen=True)
class RenderMesh:
    """A mesh to render, in world coordinates.

    id: written to the id buffer where this mesh is the first hit (> 0; 0 means 'nothing').
    vertices: float64 [v, 3] world frame, metres. faces: int64 [f, 3].
    face_colors: float32 [f, 3] albedo in [0, 1] per face.
    face_textures: uint8 [f] ``Texture`` code per face.
    world_from_local: float64 [4, 4] rigid frame in which procedural textures are evaluated (the object's
        canonical frame), so that every view of a surface shows the same pattern.
    texture_seed: a number in [0, 1) that varies the pattern between meshes.
    """

    id: int
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    face_colors: NDArray[np.float32]
    face_textures: NDArray[np.uint8]
    world_from_local: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    texture_seed: float = 0.0

    @classmethod
    def uniform(
        cls,
        id: int,
        vertices: NDArray,
        faces: NDArray,
        color: Sequence[float],
        texture: int = Texture.PLAIN,
        world_from_local: NDArray | None = None,
        texture_seed: float = 0.0,
    ) -> RenderMesh:
        """A mesh with one colour and one texture on every face."""
        faces = np.asarray(faces, np.int64).reshape(-1, 3)
        n = len(faces)
        return cls(
            id=int(id),
            vertices=np.asarray(vertices, np.float64).reshape(-1, 3),
            faces=faces,
            face_colors=np.tile(np.asarray(color, np.float32).reshape(1, 3), (n, 1)),
            face_textures=np.full(n, texture, np.uint8),
            world_from_local=np.eye(4) if world_from_local is None else np.asarray(world_from_local, np.float64),
            texture_seed=float(texture_seed),
        )


@dataclass(frozen=True)
class RayHits:
    """First hits of one camera's pixel rays. Arrays are [H, W] (or [H, W, 3]); misses are marked by ``hit``.

    depth: float32 metres along camera z (0 = miss). ids: int32 mesh id (0 = miss).
    mesh_index: int32 index of the hit mesh in the renderer's list (-1 = miss).
    face_index: int64 index into the renderer's concatenated faces (-1 = miss).
    points: float32 [H, W, 3] world hit points. normals: float32 [H, W, 3] unit face normals facing the camera.
    """

    hit: NDArray[np.bool_]
    depth: NDArray[np.float32]
    ids: NDArray[np.int32]
    mesh_index: NDArray[np.int32]
    face_index: NDArray[np.int64]
    points: NDArray[np.float32]
    normals: NDArray[np.float32]


def camera_rays(camera: Camera) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ray origin [3] and directions [H, W, 3] (world frame, camera-z component 1) through pixel centres."""
    w, h = camera.width, camera.height
    K = np.asarray(camera.K, np.float64)
    u = (np.arange(w) + 0.5 - K[0, 2]) / K[0, 0]
    v = (np.arange(h) + 0.5 - K[1, 2]) / K[1, 1]
    dirs_cam = np.empty((h, w, 3))
    dirs_cam[..., 0] = u[None, :]
    dirs_cam[..., 1] = v[:, None]
    dirs_cam[..., 2] = 1.0
    rot = np.asarray(camera.world_from_cam, np.float64)[:3, :3]
    return np.asarray(camera.world_from_cam[:3, 3], np.float64), dirs_cam @ rot.T


class RayCaster:
    """A static set of meshes in an Open3D ``RaycastingScene``; cast camera rays or arbitrary rays.

    threads: worker threads for a cast (0 lets Open3D choose).
    """

    def __init__(self, meshes: Sequence[RenderMesh], threads: int = 0):
        import open3d as o3d

        if not meshes:
            raise ValueError("RayCaster needs at least one mesh")
        self._o3d = o3d
        self.meshes = tuple(meshes)
        self.threads = int(threads)
        self.scene = o3d.t.geometry.RaycastingScene()
        for mesh in self.meshes:
            if len(mesh.faces) == 0:
                raise ValueError(f"mesh {mesh.id} has no faces")
            self.scene.add_triangles(
                o3d.core.Tensor(np.ascontiguousarray(mesh.vertices, np.float32)),
                o3d.core.Tensor(np.ascontiguousarray(mesh.faces, np.uint32)),
            )
        counts = np.array([len(m.faces) for m in self.meshes], np.int64)
        self.face_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.mesh_ids = np.array([m.id for m in self.meshes], np.int32)
        self._dirs_cache: dict[bytes, NDArray[np.float32]] = {}

    def cast(self, origins: NDArray, directions: NDArray) -> dict[str, NDArray]:
        """Raw first hits of rays [..., 3] + [..., 3]: t (inf on miss), hit, mesh index (-1), face index (-1),
        normals (unit face normals, not oriented)."""
        shape = directions.shape[:-1]
        rays = np.empty((*shape, 6), np.float32)
        rays[..., :3] = origins
        rays[..., 3:] = directions
        out = self.scene.cast_rays(self._o3d.core.Tensor(rays), nthreads=self.threads)
        t = out["t_hit"].numpy()
        hit = np.isfinite(t)
        geom = np.where(hit, out["geometry_ids"].numpy(), 0).astype(np.int64)
        prim = np.where(hit, out["primitive_ids"].numpy(), 0).astype(np.int64)
        return {
            "t": t,
            "hit": hit,
            "mesh_index": np.where(hit, geom, -1).astype(np.int32),
            "face_index": np.where(hit, self.face_offsets[geom] + prim, -1),
            "normals": out["primitive_normals"].numpy(),
        }

    def occluded(self, points: NDArray, targets: NDArray, eps: float = 1e-3) -> NDArray[np.bool_]:
        """Whether the segment from each point [n, 3] to its target [n, 3] (or one target [3]) hits a mesh."""
        d = (np.broadcast_to(targets, points.shape) - points).astype(np.float32)
        length = np.sqrt(np.einsum("ni,ni->n", d, d))
        unit = d / np.maximum(length, 1e-12)[:, None]
        raw = self.cast(points + unit * eps, unit)
        return raw["t"] < (length - 2 * eps)

    def _camera_dirs(self, camera: Camera) -> NDArray[np.float32]:
        """Ray directions [H, W, 3] in the camera frame (z = 1), cached per intrinsics and size."""
        key = np.asarray(camera.K, np.float64).tobytes() + np.array([camera.width, camera.height]).tobytes()
        dirs = self._dirs_cache.get(key)
        if dirs is None:
            K = np.asarray(camera.K, np.float64)
            u = (np.arange(camera.width) + 0.5 - K[0, 2]) / K[0, 0]
            v = (np.arange(camera.height) + 0.5 - K[1, 2]) / K[1, 1]
            dirs = np.empty((camera.height, camera.width, 3), np.float32)
            dirs[..., 0] = u[None, :]
            dirs[..., 1] = v[:, None]
            dirs[..., 2] = 1.0
            self._dirs_cache[key] = dirs
        return dirs

    def cast_camera(self, camera: Camera) -> RayHits:
        """First hit per pixel of ``camera``."""
        rot = np.asarray(camera.world_from_cam[:3, :3], np.float32)
        origin = np.asarray(camera.world_from_cam[:3, 3], np.float32)
        dirs = self._camera_dirs(camera) @ rot.T
        raw = self.cast(origin, dirs)
        hit = raw["hit"]
        t = np.where(hit, raw["t"], np.float32(0.0))
        normals = raw["normals"]
        facing = np.einsum("hwc,hwc->hw", normals, dirs) > 0
        normals = np.where(facing[..., None], -normals, normals)
        ids = np.where(hit, self.mesh_ids[np.maximum(raw["mesh_index"], 0)], 0).astype(np.int32)
        return RayHits(
            hit=hit,
            depth=t.astype(np.float32),
            ids=ids,
            mesh_index=raw["mesh_index"],
            face_index=raw["face_index"],
            points=origin + dirs * t[..., None],
            normals=normals,
        )
