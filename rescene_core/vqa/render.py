"""Viewpoints inside the room and rendered views of the assembled scene.

A viewpoint is an eye position inside the floor polygon (away from walls and object footprints) at
1.2-1.7 m above the floor, looking at a target object's box centre. Views are ray-cast with the project's
CPU renderer (``rescene_core.render``, Open3D ``RaycastingScene``): one id buffer gives the visible objects
(an object is visible when it covers ``VqaConfig.min_visible_pixels``), and the RGB image is saved as PNG.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from PIL import Image
from shapely import contains_xy
from shapely.geometry import box
from shapely.ops import unary_union

from rescene_core.export import ExportConfig, shell_meshes
from rescene_core.geometry.camera import intrinsics_from_fov, look_at
from rescene_core.io import write_bytes_atomic
from rescene_core.paths import VQA, VQA_VIEW, in_folder
from rescene_core.records import Camera
from rescene_core.render import Light, RenderedFrame, Renderer, RenderMesh, Shading, Texture
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.scene import VqaInputError, VqaScene

RENDER_BACKEND = "open3d-raycast"
"""The renderer the views come from (the paper used a headless Blender agent)."""


@dataclass(frozen=True)
class Viewpoint:
    """One sampled camera and what it sees.

    id: 'view_000', ... (the PNG is views/<id>.png). target: the object the camera looks at.
    camera: pinhole camera, world_from_cam in OpenCV axes (x right, y down, z forward), metres.
    visible: object id -> pixels covered in the id buffer, objects with >= min_visible_pixels only.
    center_id: object id under the image centre pixel (0 = no object: shell or nothing).
    faint: object id -> pixels for objects seen below ``min_visible_pixels`` (not visible; questions whose
    answer would change if they were are filtered). agent: the walk's record of the capture (walk, step,
    action, yaw_deg, pitch_deg), None for targeted viewpoints.
    """

    id: str
    target: int
    camera: Camera
    visible: dict[int, int] = field(default_factory=dict)
    center_id: int = 0
    faint: dict[int, int] = field(default_factory=dict)
    agent: dict[str, Any] | None = None

    @property
    def eye(self) -> NDArray[np.float64]:
        return np.asarray(self.camera.world_from_cam[:3, 3], np.float64)

    def to_json(self) -> dict[str, Any]:
        out = {
            "id": self.id,
            "image": in_folder(".", VQA_VIEW, VQA, view=self.id).as_posix(),
            "target": self.target,
            "eye": self.eye.tolist(),
            "world_from_cam": np.asarray(self.camera.world_from_cam).tolist(),
            "K": np.asarray(self.camera.K).tolist(),
            "width": self.camera.width,
            "height": self.camera.height,
            "visible": {str(k): int(v) for k, v in sorted(self.visible.items())},
            "center_id": self.center_id,
        }
        if self.faint:
            out["faint"] = {str(k): int(v) for k, v in sorted(self.faint.items())}
        if self.agent is not None:
            out["agent"] = self.agent
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Viewpoint:
        """The viewpoint of ``to_json`` (the camera, visibility and walk record)."""
        camera = Camera(
            np.asarray(d["K"], np.float64),
            np.asarray(d["world_from_cam"], np.float64),
            int(d["width"]),
            int(d["height"]),
        )
        return cls(
            str(d["id"]),
            int(d.get("target", 0)),
            camera,
            {int(k): int(v) for k, v in d.get("visible", {}).items()},
            int(d.get("center_id", 0)),
            {int(k): int(v) for k, v in d.get("faint", {}).items()},
            d.get("agent"),
        )


def intrinsics(config: VqaConfig) -> NDArray[np.float64]:
    """Pinhole K [3, 3] (pixels) of the rendered views: square pixels, principal point at the centre."""
    return intrinsics_from_fov(config.image_width, config.image_height, config.hfov_deg)


def _label_color(label: str) -> tuple[float, float, float]:
    """A stable albedo per label (so one label looks the same in every view)."""
    digest = hashlib.sha256(label.encode()).digest()
    hue = digest[0] / 255.0
    r, g, b = (np.cos(2 * np.pi * (hue + k / 3.0)) * 0.25 + 0.55 for k in range(3))
    return float(r), float(g), float(b)


def scene_meshes(scene: VqaScene, config: VqaConfig) -> list[RenderMesh]:
    """Objects (mesh id = instance id) plus the room shell's floor slab and walls (negative ids)."""

    meshes = [
        RenderMesh.uniform(o.id, o.vertices, o.faces, _label_color(o.label), Texture.PLAIN) for o in scene.objects
    ]
    height = scene.shell.ceiling_height or config.default_ceiling_height
    shell = shell_meshes(scene.shell, ExportConfig(wall_height=height))
    for k, (name, mesh) in enumerate(sorted(shell.items())):
        floor = name == "shell_floor"
        meshes.append(
            RenderMesh.uniform(
                -(k + 1),
                mesh.vertices,
                mesh.faces,
                (0.62, 0.5, 0.38) if floor else (0.86, 0.85, 0.8),
                Texture.PLANKS if floor else Texture.PAINT,
            )
        )
    return meshes


def make_renderer(scene: VqaScene, config: VqaConfig) -> Renderer:
    """A renderer of the scene lit by one ceiling-centred light (over the floor polygon's centroid)."""
    poly = scene.shell.polygon()
    height = scene.shell.ceiling_height or config.default_ceiling_height
    c = poly.centroid
    light = Light((float(c.x), float(c.y), scene.floor_height() + height - config.light_below_ceiling))
    return Renderer(scene_meshes(scene, config), Shading(lights=(light,)))


def free_space(scene: VqaScene, config: VqaConfig):
    """Where an eye may stand: the floor polygon shrunk by ``wall_clearance`` minus every object's footprint
    grown by ``object_clearance`` (a shapely geometry, world x/y in metres)."""

    poly = scene.shell.polygon()
    if not poly.is_valid or poly.area <= 0:
        raise VqaInputError("the room shell's floor polygon is invalid or has no area")
    free = poly.buffer(-config.wall_clearance)
    top = scene.floor_height() + config.eye_height_max
    footprints = [
        box(o.box_min[0], o.box_min[1], o.box_max[0], o.box_max[1]).buffer(config.object_clearance)
        for o in scene.objects
        if o.box_min[2] < top
    ]
    if footprints:
        free = free.difference(unary_union(footprints))
    return free


def visible_objects(frame_ids: NDArray[np.int32], min_pixels: int) -> dict[int, int]:
    """Object id -> pixel count for objects (ids > 0) covering at least ``min_pixels`` of an id buffer."""
    ids, counts = np.unique(frame_ids[frame_ids > 0], return_counts=True)
    return {int(i): int(n) for i, n in zip(ids, counts, strict=True) if n >= min_pixels}


def sample_viewpoints(
    scene: VqaScene, config: VqaConfig, renderer: Renderer, rng: np.random.Generator
) -> tuple[list[Viewpoint], dict[int, RenderedFrame]]:
    """Up to ``config.views`` viewpoints, each looking at a different target (targets in a seeded random
    order, repeated when there are more views than objects). A sample is kept when its eye lies in
    ``free_space`` and its target covers ``min_visible_pixels`` (no wall or object blocks it).

    Returns the viewpoints and their rendered frames (index in the list -> frame).
    """

    free = free_space(scene, config)
    if config.views == 0:
        return [], {}
    if free.is_empty:
        raise VqaInputError("no free floor space for a viewpoint (room too small for the clearances)")
    K = intrinsics(config)
    x0, y0, x1, y1 = free.bounds
    z_floor = scene.floor_height()
    order = [int(i) for i in rng.permutation(scene.ids)]
    views: list[Viewpoint] = []
    frames: dict[int, RenderedFrame] = {}
    for k in range(max(config.views, 0) * 2):
        if len(views) >= config.views:
            break
        target = scene.object(order[k % len(order)])
        centre = target.center
        xy = np.column_stack(
            [rng.uniform(x0, x1, config.max_view_attempts), rng.uniform(y0, y1, config.max_view_attempts)]
        )
        heights = rng.uniform(config.eye_height_min, config.eye_height_max, config.max_view_attempts)
        dist = np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1])
        ok = contains_xy(free, xy[:, 0], xy[:, 1])
        ok &= (dist >= config.view_distance_min) & (dist <= config.view_distance_max)
        for i in np.flatnonzero(ok):
            eye = np.array([xy[i, 0], xy[i, 1], z_floor + heights[i]])
            camera = Camera(K, look_at(eye, centre), config.image_width, config.image_height)
            frame = renderer.render(camera)
            visible = visible_objects(frame.ids, config.min_visible_pixels)
            if target.id not in visible:
                continue
            h, w = frame.ids.shape
            centre_id = int(frame.ids[h // 2, w // 2])
            vp = Viewpoint(f"view_{len(views):03d}", target.id, camera, visible, max(centre_id, 0))
            frames[len(views)] = frame
            views.append(vp)
            break
    return views, frames


def save_png(path: str | Path, rgb: NDArray[np.uint8]) -> Path:
    """Write an RGB image uint8 [H, W, 3] as PNG, atomically."""

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, np.uint8)).save(buf, format="PNG")
    return write_bytes_atomic(path, buf.getvalue())
