"""A small ray-cast room (floor, walls, coloured boxes) written as a capture, for the HierView and shell tests.

Cameras stand inside a 4 x 3 m room looking outwards and down; masks, depth and colours come from an Open3D
ray cast, and instance point clouds are sampled on the meshes, so masks and points agree exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import open3d as o3d
import trimesh

from rescene_core.capture import CaptureArrays, points_to_csr, write_capture
from rescene_core.records import Instance, InstanceId

ROOM = (4.0, 3.0, 2.5)
THIN = 0.002
"""Thickness of the floor and wall slabs (m): thin, so each is one surface for plane fitting."""

OBJECTS = [
    # id, label, centre (x, y), size (sx, sy, sz), colour
    (10, "cabinet", (0.5, 0.4), (0.6, 0.5, 1.2), (200, 40, 40)),
    (11, "table", (2.0, 1.5), (1.0, 0.6, 0.7), (40, 160, 40)),
    (12, "sofa", (3.3, 2.4), (1.0, 0.8, 0.8), (40, 60, 200)),
    (13, "chair", (2.9, 0.5), (0.5, 0.5, 0.9), (220, 200, 40)),
    (14, "box", (0.6, 2.5), (0.5, 0.5, 0.5), (180, 60, 200)),
    (15, "lamp", (1.2, 1.3), (0.3, 0.3, 1.5), (40, 200, 200)),
]

OVERVIEWS = [(0.4, 0.3, 2.2), (3.6, 2.7, 2.2), (3.6, 0.3, 2.2)]
"""Camera centres of the overview frames (corners, looking at the room centre)."""


def _box(lo, hi) -> o3d.geometry.TriangleMesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    mesh = o3d.geometry.TriangleMesh.create_box(*(hi - lo))
    mesh.translate(lo)
    return mesh


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """world_from_cam [4, 4] of an OpenCV camera at ``eye`` looking at ``target``."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, y, z])
    pose[:3, 3] = eye
    return pose


@dataclass
class Room:
    arrays: CaptureArrays
    meshes: dict[int, o3d.geometry.TriangleMesh] = field(default_factory=dict)
    labels: dict[int, str] = field(default_factory=dict)


def make_room(
    frames: int = 16,
    width: int = 96,
    height: int = 72,
    open_side: bool = False,
    structural: bool = True,
    closeups: int = 2,
    overviews: int = 2,
    seed: int = 0,
    point_density: float = 600.0,
) -> Room:
    """Render the room. Frames: ``frames`` ring views, ``overviews`` corner views of the room centre, then
    ``closeups`` close-ups that truncate the table (id 11)."""
    rng = np.random.default_rng(seed)
    sx, sy, sz = ROOM
    meshes: dict[int, o3d.geometry.TriangleMesh] = {1: _box((0, 0, -THIN), (sx, sy, 0))}
    labels = {1: "floor"}
    colours = {1: (150, 130, 110)}
    walls = {
        2: ((-THIN, 0, 0), (0, sy, sz)),
        3: ((sx, 0, 0), (sx + THIN, sy, sz)),
        4: ((0, -THIN, 0), (sx, 0, sz)),
        5: ((0, sy, 0), (sx, sy + THIN, sz)),
    }
    if open_side:
        walls.pop(5)
    for wid, (lo, hi) in walls.items():
        meshes[wid] = _box(lo, hi)
        labels[wid] = "wall"
        colours[wid] = (225, 225, 215)
    for oid, label, (cx, cy), (ox, oy, oz), colour in OBJECTS:
        meshes[oid] = _box((cx - ox / 2, cy - oy / 2, 0), (cx + ox / 2, cy + oy / 2, oz))
        labels[oid] = label
        colours[oid] = colour

    scene = o3d.t.geometry.RaycastingScene()
    geom_to_id = {}
    for inst_id, mesh in meshes.items():
        gid = scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
        geom_to_id[gid] = inst_id
    lut = np.zeros(max(geom_to_id) + 2, np.int32)
    for gid, inst_id in geom_to_id.items():
        lut[gid] = inst_id

    f = 0.8 * width
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])
    centre = np.array([sx / 2, sy / 2])
    poses = []
    for t in range(frames):
        a = 2 * np.pi * t / frames
        d = np.array([np.cos(a), np.sin(a)])
        eye = np.array([*(centre - 0.8 * d), 1.6])
        target = np.array([*(centre + 1.6 * d), 0.4])
        poses.append(look_at(eye, target))
    for eye in OVERVIEWS[:overviews]:
        poses.append(look_at(eye, (2.0, 1.5, 0.3)))
    for c in range(closeups):
        eye = np.array([1.8 + 0.2 * c, 0.95, 1.0])
        poses.append(look_at(eye, (1.8 + 0.2 * c, 1.5, 0.55)))
    poses = np.asarray(poses)
    total = len(poses)

    masks = np.zeros((total, height, width), np.int32)
    depth = np.zeros((total, height, width), np.float32)
    rgb = np.zeros((total, height, width, 3), np.uint8)
    colour_table = np.zeros((lut.max() + 1, 3))
    for inst_id, col in colours.items():
        colour_table[inst_id] = col
    for t, world_from_cam in enumerate(poses):
        cam_from_world = np.linalg.inv(world_from_cam)
        rays = scene.create_rays_pinhole(
            o3d.core.Tensor(K), o3d.core.Tensor(cam_from_world), width_px=width, height_px=height
        )
        ans = scene.cast_rays(rays)
        t_hit = ans["t_hit"].numpy()
        hit = np.isfinite(t_hit)
        gids = ans["geometry_ids"].numpy().astype(np.int64)
        ids = np.where(hit, lut[np.clip(gids, 0, len(lut) - 1)], 0)
        r = rays.numpy()
        pts = r[..., :3] + r[..., 3:] * np.where(hit, t_hit, 0)[..., None]
        cam = pts @ cam_from_world[:3, :3].T + cam_from_world[:3, 3]
        depth[t] = np.where(hit, cam[..., 2], 0)
        masks[t] = ids
        normals = ans["primitive_normals"].numpy()
        shade = 0.6 + 0.4 * np.abs(normals @ np.array([0.3, 0.5, 0.81]))
        img = colour_table[ids] * shade[..., None] + rng.normal(0, 4, (height, width, 3))
        rgb[t] = np.clip(img, 0, 255).astype(np.uint8)

    clouds = {}
    for inst_id, mesh in meshes.items():
        n = max(50, int(mesh.get_surface_area() * point_density))
        tm = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.triangles), process=False)
        pts = np.asarray(trimesh.sample.sample_surface(tm, n, seed=seed + inst_id)[0], np.float32)
        clouds[inst_id] = (pts, np.tile(np.asarray(colours[inst_id], np.uint8), (len(pts), 1)))
    ids, offsets, pts, cols = points_to_csr(clouds)
    instances = tuple(
        Instance(InstanceId(i), labels[i], structural and labels[i] in ("floor", "wall")) for i in sorted(meshes)
    )
    arrays = CaptureArrays(
        scene_id="room",
        rgb=rgb,
        K=np.tile(K, (total, 1, 1)),
        world_from_cam=poses,
        instance_masks=masks,
        instances=instances,
        point_ids=ids,
        point_offsets=offsets,
        points=pts,
        colors=cols,
        depth=depth,
        source="test-room",
    )
    return Room(arrays, meshes, labels)


def write_room(path: Path, room: Room) -> Path:
    return write_capture(path, room.arrays)
