"""One builder for test captures, on top of the synthetic generator's renderer.

Two kinds of capture, both rendered by ``rescene_core.render.Renderer`` (the ray caster that
``rescene_core.capture.synth`` renders its rooms with), so masks, depth, colours and points always agree:

    synth_arrays("tiny", seed=0)          # a generated furnished room (make_scene), cached per process
    box_capture_arrays(boxes, cameras)    # boxes placed by hand, for tests that need a known layout

``box_capture_arrays`` takes ``Box`` records (id, label, world-frame corners, colour) and camera poses
(``rescene_core.geometry.camera.look_at``, re-exported here), renders RGB, instance masks and depth, and builds each instance's point cloud either by
sampling its box surface (``points="surface"``: every face, seen or not) or from the rendered hits
(``points="depth"``: only what the cameras saw, like a fused capture).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.capture import CaptureArrays, points_to_csr, write_capture
from rescene_core.capture.synth import SynthScene, make_scene
from rescene_core.export import ExportObject
from rescene_core.geometry import sim3
from rescene_core.geometry.camera import look_at
from rescene_core.records import Camera, Instance, InstanceId, Plane, RoomShell, WallPlane
from rescene_core.render import Light, Renderer, RenderMesh, Shading

__all__ = ["Box", "box_capture_arrays", "look_at", "pinhole", "synth_arrays", "synth_scene", "write_arrays"]


@dataclass(frozen=True)
class Box:
    """An axis-aligned box instance: world-frame corners ``lo``/``hi`` (m), 8-bit RGB ``color``."""

    id: int
    label: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    color: tuple[int, int, int]
    structural: bool = False

    @classmethod
    def centred(cls, id: int, label: str, centre, extents, color, structural: bool = False) -> Box:
        """A box from its centre and full extents (m)."""
        c, e = np.asarray(centre, float), np.asarray(extents, float) / 2
        return cls(id, label, tuple(c - e), tuple(c + e), tuple(int(v) for v in color), structural)

    def mesh(self) -> trimesh.Trimesh:
        return trimesh.creation.box(bounds=np.array([self.lo, self.hi], float))


ONE_WALL_SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    ceiling_height=2.5,
)
"""A 4 x 4 m room, 2.5 m high, with one wall along y = -2 (the simulation exports' and checks' tests)."""

CORNER_SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(
        WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),
        WallPlane(1, Plane((1.0, 0.0, 0.0), 2.0), ((-2.0, 2.0), (-2.0, -2.0))),
    ),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    ceiling_height=2.5,
)
"""The same room with a second wall along x = -2, meeting the first in a corner."""


def export_box(instance: int, label: str, centre, extents=(0.4, 0.4, 0.4)):
    """An ExportObject: a box of ``extents`` (m) centred at world ``centre`` [3], unrotated, scale 1 (the
    physics checks' tests)."""
    box = trimesh.creation.box(extents)
    return ExportObject(instance, label, box.vertices, box.faces, sim3.sim3_from_parts(1.0, np.eye(3), centre))


def pinhole(width: int, height: int, focal: float) -> NDArray[np.float64]:
    """Intrinsics [3, 3] with the principal point at the image centre (pixel centres at half-integers)."""
    return np.array([[focal, 0.0, width / 2], [0.0, focal, height / 2], [0.0, 0.0, 1.0]])


def box_capture_arrays(
    boxes: Sequence[Box],
    world_from_cam: NDArray,
    K: NDArray,
    width: int,
    height: int,
    *,
    points: str = "surface",
    point_density: float = 600.0,
    min_points: int = 50,
    rgb_noise: float = 0.0,
    lights: Sequence[Light] = (),
    ambient: float = 1.0,
    seed: int = 0,
    scene_id: str = "test-boxes",
) -> CaptureArrays:
    """Render ``boxes`` from every camera in ``world_from_cam`` [T, 4, 4] (OpenCV axes) as a capture.

    points: "surface" samples ``point_density`` points per m^2 of each box surface (at least ``min_points``);
        "depth" keeps the rendered hit points of each instance over all frames.
    rgb_noise: standard deviation of Gaussian image noise (8-bit levels). lights/ambient: the shading
        (the default, ambient 1 and no lights, gives each box its flat colour).
    """
    if points not in ("surface", "depth"):
        raise ValueError(f"points must be 'surface' or 'depth', not {points!r}")
    rng = np.random.default_rng(seed)
    meshes = {b.id: b.mesh() for b in boxes}
    render_meshes = [
        RenderMesh.uniform(b.id, meshes[b.id].vertices, meshes[b.id].faces, np.asarray(b.color, float) / 255.0)
        for b in boxes
    ]
    renderer = Renderer(render_meshes, Shading(lights=tuple(lights), ambient=ambient, shadows=False, gamma=1.0))
    poses = np.asarray(world_from_cam, np.float64).reshape(-1, 4, 4)
    K = np.asarray(K, np.float64)
    frames = len(poses)
    rgb = np.zeros((frames, height, width, 3), np.uint8)
    masks = np.zeros((frames, height, width), np.int32)
    depth = np.zeros((frames, height, width), np.float32)
    seen: dict[int, list[NDArray]] = {b.id: [] for b in boxes}
    for t, pose in enumerate(poses):
        frame = renderer.render(Camera(K, pose, width, height))
        masks[t], depth[t] = frame.ids, frame.depth
        img = frame.rgb.astype(np.float64)
        if rgb_noise > 0:
            img += rng.normal(0.0, rgb_noise, img.shape)
        rgb[t] = np.clip(np.round(img), 0, 255).astype(np.uint8)
        if points == "depth":
            for b in boxes:
                seen[b.id].append(frame.hits.points[frame.ids == b.id])

    clouds = {}
    for b in boxes:
        if points == "surface":
            n = max(min_points, int(meshes[b.id].area * point_density))
            pts = np.asarray(trimesh.sample.sample_surface(meshes[b.id], n, seed=seed + b.id)[0], np.float32)
        else:
            pts = np.concatenate(seen[b.id]).astype(np.float32) if seen[b.id] else np.zeros((0, 3), np.float32)
        clouds[b.id] = (pts, np.tile(np.asarray(b.color, np.uint8), (len(pts), 1)))
    ids, offsets, pts, cols = points_to_csr(clouds)
    return CaptureArrays(
        scene_id=scene_id,
        rgb=rgb,
        K=np.tile(K, (frames, 1, 1)),
        world_from_cam=poses,
        instance_masks=masks,
        instances=tuple(Instance(InstanceId(b.id), b.label, b.structural) for b in sorted(boxes, key=lambda b: b.id)),
        point_ids=ids,
        point_offsets=offsets,
        points=pts,
        colors=cols,
        depth=depth,
        source="test",
    )


@lru_cache(maxsize=8)
def synth_scene(preset: str = "tiny", seed: int = 0) -> SynthScene:
    """``make_scene(preset, seed)``, generated once per test process (treat the result as read-only)."""
    return make_scene(preset, seed)


def synth_arrays(preset: str = "tiny", seed: int = 0) -> CaptureArrays:
    """The arrays of ``synth_scene(preset, seed)``."""
    return synth_scene(preset, seed).arrays


def write_arrays(path: str | Path, arrays: CaptureArrays) -> Path:
    """Write ``arrays`` as a capture at ``path`` (no ground truth); returns the path."""
    return write_capture(Path(path), arrays)
