"""A small self-consistent capture and run directory for the evaluation tests.

A 4 m x 4 m room (floor, four walls) with a table and a box on the floor; frames rendered with the
project's renderer (flat shading: what ``evaluation.rendering`` renders), so a run that places the true
meshes reproduces the frames exactly. Ground truth in ``gt/``; the run directory holds what `rescene
run` exports (scene.json, scene.glb, objects/) and keyframes.json.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from rescene_core.capture import CaptureArrays, points_to_csr, write_capture
from rescene_core.capture.ground_truth import GroundTruth, GtObject, GtRelation, write_ground_truth
from rescene_core.export import ExportConfig, ExportObject, export_scene, shell_meshes
from rescene_core.io import write_json_atomic
from rescene_core.records import (
    Camera,
    Edge,
    Instance,
    InstanceId,
    Plane,
    Relation,
    RoomShell,
    Root,
    SceneGraph,
    WallPlane,
)
from rescene_core.render import Renderer, RenderMesh, Shading, Texture
from rescene_core.vqa.render import look_at

W, H = 96, 72
COLORS = {1: (0.55, 0.35, 0.2), 2: (0.2, 0.45, 0.7), 10: (0.6, 0.5, 0.4), 11: (0.85, 0.85, 0.8)}
"""Albedo per capture instance: 1 table, 2 box, 10 floor, 11 walls."""


def room_shell() -> RoomShell:
    corners = [(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)]
    walls = []
    for k in range(4):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
        d = np.array([x1 - x0, y1 - y0]) / 4.0
        n = (-d[1], d[0])  # inward normal of a counter-clockwise polygon
        offset = -(n[0] * x0 + n[1] * y0)
        walls.append(WallPlane(k, Plane((float(n[0]), float(n[1]), 0.0), float(offset)), ((x0, y0), (x1, y1))))
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), tuple(walls), tuple(corners), ceiling_height=2.5)


def objects() -> dict[int, tuple[str, trimesh.Trimesh]]:
    """Capture instance id -> (label, canonical mesh with its bottom at z = 0) and the world poses."""
    table = trimesh.creation.box(extents=[1.0, 0.6, 0.7])
    table.apply_translation([0, 0, 0.35])
    box = trimesh.creation.box(extents=[0.4, 0.4, 0.5])
    box.apply_translation([0, 0, 0.25])
    return {1: ("table", table), 2: ("box", box)}


POSES = {1: [0.6, 0.4, 0.0], 2: [-0.8, -0.6, 0.0]}


def world_from(instance: int, shift: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = POSES[instance]
    m[0, 3] += shift
    return m


def cameras(n: int = 8) -> list[Camera]:
    K = np.array([[70.0, 0, W / 2], [0, 70.0, H / 2], [0, 0, 1]])
    out = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        eye = np.array([1.5 * np.cos(a), 1.5 * np.sin(a), 1.5])
        out.append(Camera(K, look_at(eye, [0.0, 0.0, 0.3]), W, H))
    return out


def _world_meshes(shift: float = 0.0) -> dict[int, trimesh.Trimesh]:
    out = {}
    for i, (_, mesh) in objects().items():
        m = mesh.copy()
        m.apply_transform(world_from(i, shift))
        out[i] = m
    return out


def write_test_capture(path: Path, depth: bool = True) -> Path:
    shell = room_shell()
    world = _world_meshes()
    render = [RenderMesh.uniform(i, m.vertices, m.faces, COLORS[i], Texture.PLAIN) for i, m in world.items()]
    for name, m in shell_meshes(shell, ExportConfig()).items():
        iid = 10 if name == "shell_floor" else 11
        render.append(RenderMesh.uniform(iid, m.vertices, m.faces, COLORS[iid], Texture.PLAIN))
    renderer = Renderer(render, Shading(lights=(), ambient=1.0, gamma=1.0))
    cams = cameras()
    frames = [renderer.render(c) for c in cams]
    clouds = {}
    for iid in (1, 2, 10, 11):
        pts = np.concatenate([f.hits.points[f.ids == iid] for f in frames])
        col = np.tile((np.asarray(COLORS[iid]) * 255 + 0.5).astype(np.uint8), (len(pts), 1))
        clouds[iid] = (pts.astype(np.float32), col)
    ids, offsets, pts, cols = points_to_csr(clouds)
    arrays = CaptureArrays(
        scene_id="evaluation-test",
        rgb=np.stack([f.rgb for f in frames]),
        K=np.stack([c.K for c in cams]),
        world_from_cam=np.stack([c.world_from_cam for c in cams]),
        instance_masks=np.stack([f.ids for f in frames]).astype(np.int32),
        instances=(
            Instance(InstanceId(1), "table"),
            Instance(InstanceId(2), "box"),
            Instance(InstanceId(10), "floor", True),
            Instance(InstanceId(11), "wall", True),
        ),
        point_ids=ids,
        point_offsets=offsets,
        points=pts,
        colors=cols,
        depth=np.stack([f.depth for f in frames]) if depth else None,
        source="test",
    )
    gt = GroundTruth(
        objects=tuple(
            GtObject(k, label, np.asarray(m.vertices), np.asarray(m.faces), world_from(k), (k,))
            for k, (label, m) in objects().items()
        ),
        relations=(GtRelation(1, Relation.RESTS_ON, Root.FLOOR), GtRelation(2, Relation.RESTS_ON, Root.FLOOR)),
        shell=shell,
    )
    return write_capture(path, arrays, extra=lambda root: write_ground_truth(root, gt))


def write_test_run(run_dir: Path, capture: Path, shift: float = 0.0, keyframes: bool = True) -> Path:
    """A run directory placing the true meshes (shifted along x by ``shift`` m)."""
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),
            Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 0.9),
        )
    )
    objs = [
        ExportObject(i, label, np.asarray(m.vertices), np.asarray(m.faces), world_from(i, shift), world_from(i, shift))
        for i, (label, m) in objects().items()
    ]
    export_scene(run_dir / "scene", objs, room_shell(), graph, [], ExportConfig(), extra={"capture": str(capture)})
    if keyframes:
        write_json_atomic(run_dir / "keyframes.json", {"frames": [0, 4]})
    return run_dir
