"""A small hand-built room for the scene-graph tests: floor, four walls, a table with a lamp on it,
a chair, a cabinet against a wall and a picture on a wall, ray-cast with Open3D from a ring of cameras.

Masks and depth come from the ray caster; each instance's point cloud is its depth back-projected over
all frames (the surfaces the capture saw). The room shell is built by hand from the known planes.
"""

from __future__ import annotations

import numpy as np
import open3d as o3d
import trimesh

from rescene_core.capture import CaptureArrays, points_to_csr
from rescene_core.records import Instance, InstanceId, Plane, Relation, RoomShell, Root, WallPlane

SIZE = 4.0
WIDTH, HEIGHT = 160, 120
FOCAL = 110.0

# id: (label, structural, box extents (x, y, z), box centre)
BOXES = {
    1: ("floor", True, (SIZE, SIZE, 0.02), (SIZE / 2, SIZE / 2, -0.01)),
    2: ("wall", True, (0.02, SIZE, 2.6), (-0.01, SIZE / 2, 1.3)),
    3: ("wall", True, (0.02, SIZE, 2.6), (SIZE + 0.01, SIZE / 2, 1.3)),
    4: ("wall", True, (SIZE, 0.02, 2.6), (SIZE / 2, -0.01, 1.3)),
    5: ("wall", True, (SIZE, 0.02, 2.6), (SIZE / 2, SIZE + 0.01, 1.3)),
    6: ("table", False, (1.0, 0.6, 0.75), (2.2, 2.3, 0.375)),
    7: ("table lamp", False, (0.2, 0.2, 0.4), (2.4, 2.35, 0.95)),
    8: ("picture", False, (0.7, 0.03, 0.45), (2.0, SIZE - 0.015, 1.6)),
    9: ("chair", False, (0.45, 0.45, 0.9), (1.3, 2.2, 0.45)),
    10: ("cabinet", False, (0.5, 1.0, 1.2), (0.25, 1.2, 0.6)),
}
GT = {
    6: (Relation.RESTS_ON, Root.FLOOR),
    7: (Relation.RESTS_ON, InstanceId(6)),
    8: (Relation.MOUNTS_ON, Root.WALL),
    9: (Relation.RESTS_ON, Root.FLOOR),
    10: (Relation.RESTS_ON, Root.FLOOR),
}


def room_shell() -> RoomShell:
    walls = (
        WallPlane(0, Plane((1.0, 0.0, 0.0), 0.0), ((0.0, 0.0), (0.0, SIZE))),
        WallPlane(1, Plane((-1.0, 0.0, 0.0), SIZE), ((SIZE, 0.0), (SIZE, SIZE))),
        WallPlane(2, Plane((0.0, 1.0, 0.0), 0.0), ((0.0, 0.0), (SIZE, 0.0))),
        WallPlane(3, Plane((0.0, -1.0, 0.0), SIZE), ((0.0, SIZE), (SIZE, SIZE))),
    )
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), walls, ((0.0, 0.0), (SIZE, 0.0), (SIZE, SIZE), (0.0, SIZE)), 2.6)


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """world_from_cam of an OpenCV camera at ``eye`` looking at ``target`` (z up)."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    out = np.eye(4)
    out[:3, :3] = np.stack([x, y, z], axis=1)
    out[:3, 3] = eye
    return out


def room_arrays(frames: int = 8, seed: int = 0, boxes: dict | None = None) -> CaptureArrays:
    """Ray-cast ``boxes`` (default BOXES: id -> (label, structural, extents, centre)) from a ring of cameras."""
    boxes = BOXES if boxes is None else boxes
    rng = np.random.default_rng(seed)
    scene = o3d.t.geometry.RaycastingScene()
    geometry_to_instance = {}
    colors = {}
    for iid, (_, _, extents, centre) in boxes.items():
        box = trimesh.creation.box(extents=extents)
        box.apply_translation(centre)
        mesh = o3d.t.geometry.TriangleMesh(
            o3d.core.Tensor(np.asarray(box.vertices, np.float32)), o3d.core.Tensor(np.asarray(box.faces, np.int32))
        )
        geometry_to_instance[scene.add_triangles(mesh)] = iid
        colors[iid] = rng.integers(40, 230, 3)
    K = np.array([[FOCAL, 0, WIDTH / 2 - 0.5], [0, FOCAL, HEIGHT / 2 - 0.5], [0, 0, 1]])
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    dirs_cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u, float)], axis=-1)
    poses, masks, depths, rgbs = [], [], [], []
    lut = np.zeros(max(geometry_to_instance) + 2, np.int32)
    for g, iid in geometry_to_instance.items():
        lut[g] = iid
    for k in range(frames):
        angle = 2 * np.pi * k / frames + 0.3
        eye = np.array([SIZE / 2 + 1.5 * np.cos(angle), SIZE / 2 + 1.5 * np.sin(angle), 1.6])
        target = np.array([SIZE / 2 - 0.6 * np.cos(angle), SIZE / 2 - 0.6 * np.sin(angle), 0.7])
        pose = look_at(eye, target)
        d = dirs_cam @ pose[:3, :3].T
        rays = np.concatenate([np.broadcast_to(eye, d.shape), d], axis=-1).astype(np.float32)
        hit = scene.cast_rays(o3d.core.Tensor(rays))
        t = hit["t_hit"].numpy()
        gid = hit["geometry_ids"].numpy().astype(np.int64)
        ok = np.isfinite(t)
        mask = np.where(ok, lut[np.where(ok, gid, len(lut) - 1)], 0).astype(np.int32)
        depth = np.where(ok, t, 0).astype(np.float32)
        rgb = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
        for iid, c in colors.items():
            rgb[mask == iid] = c
        poses.append(pose)
        masks.append(mask)
        depths.append(depth)
        rgbs.append(rgb)
    masks_a, depth_a, poses_a = np.stack(masks), np.stack(depths), np.stack(poses)
    clouds = {}
    for iid in boxes:
        pts = []
        for k in range(frames):
            m = (masks_a[k] == iid) & (depth_a[k] > 0)
            vv, uu = np.nonzero(m)
            z = depth_a[k][vv, uu]
            cam = np.stack([(uu - K[0, 2]) / K[0, 0] * z, (vv - K[1, 2]) / K[1, 1] * z, z], axis=1)
            pts.append(cam @ poses_a[k][:3, :3].T + poses_a[k][:3, 3])
        p = np.concatenate(pts) if pts else np.zeros((0, 3))
        clouds[iid] = (p.astype(np.float32), np.tile(colors[iid].astype(np.uint8), (len(p), 1)))
    ids, offsets, points, cols = points_to_csr(clouds)
    instances = tuple(Instance(InstanceId(i), label, structural) for i, (label, structural, _, _) in boxes.items())
    return CaptureArrays(
        scene_id="test-room",
        rgb=np.stack(rgbs),
        K=np.tile(K, (frames, 1, 1)),
        world_from_cam=poses_a,
        instance_masks=masks_a,
        instances=instances,
        point_ids=ids,
        point_offsets=offsets,
        points=points,
        colors=cols,
        depth=depth_a,
        source="test",
    )
