"""What one frame shows: its visible object instances, their display ids, and their visible 3D points.

Display ids are the small numbers drawn on the overlay image and used in the prompt; they are 1..n in
ascending order of the canonical instance id, one mapping per frame (``FrameView.display_to_instance``).
Structural instances (floor, wall, ceiling) get no display id: they are the hidden roots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.capture import Capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import Camera, InstanceId

MAX_VISIBLE_POINTS = 6000
"""Most back-projected depth points kept per instance and frame (strided subsample, deterministic)."""


@dataclass(frozen=True)
class VisibleInstance:
    """One instance shown in a frame: canonical id, display id, category label, mask pixel count."""

    instance: InstanceId
    display: int
    label: str
    pixels: int

    def to_json(self) -> dict:
        return {"instance": int(self.instance), "display": self.display, "label": self.label, "pixels": self.pixels}


@dataclass(frozen=True)
class FrameView:
    """One frame's image, masks and visible instances.

    rgb: uint8 [H, W, 3]. mask: int32 [H, W] panoptic ids (0 = none). depth: float32 [H, W] metres along
    camera z (0 = invalid) or None when the capture has no depth. camera: the frame's calibrated camera.
    """

    frame: int
    camera: Camera
    rgb: NDArray[np.uint8]
    mask: NDArray[np.int32]
    depth: NDArray[np.float32] | None
    visible: tuple[VisibleInstance, ...]

    @property
    def display_to_instance(self) -> dict[int, InstanceId]:
        return {v.display: v.instance for v in self.visible}

    @property
    def instance_to_display(self) -> dict[InstanceId, int]:
        return {v.instance: v.display for v in self.visible}

    @property
    def categories(self) -> dict[int, str]:
        """Display id -> the capture's category label (fixed: the model may not change it)."""
        return {v.display: v.label for v in self.visible}


def frame_view(capture: Capture, frame: int, config: SceneGraphConfig) -> FrameView:
    """Read frame ``frame`` of ``capture`` and list the object instances with >= min_visible_pixels pixels."""
    if not 0 <= frame < capture.num_frames:
        raise ValueError(f"frame {frame} is outside the capture's {capture.num_frames} frames")
    mask = np.asarray(capture.instance_masks[frame], dtype=np.int32)
    rgb = np.asarray(capture.rgb[frame], dtype=np.uint8)
    depth = None if capture.depth is None else np.asarray(capture.depth[frame], dtype=np.float32)
    ids, counts = np.unique(mask[mask > 0], return_counts=True)
    objects = {int(i.id): i for i in capture.object_instances}
    shown = [(int(i), int(c)) for i, c in zip(ids, counts) if int(i) in objects and c >= config.min_visible_pixels]
    visible = tuple(
        VisibleInstance(InstanceId(iid), k + 1, objects[iid].label, pixels) for k, (iid, pixels) in enumerate(shown)
    )
    return FrameView(frame, capture.camera(frame), rgb, mask, depth, visible)


def backproject(view: FrameView, pixels: NDArray[np.bool_]) -> NDArray[np.float64]:
    """World points [n, 3] of the pixels in ``pixels`` [H, W] with valid depth (needs depth)."""
    if view.depth is None:
        raise ValueError("the capture has no depth; use the instance point clouds instead")
    v, u = np.nonzero(pixels & (view.depth > 0) & np.isfinite(view.depth))
    if len(v) > MAX_VISIBLE_POINTS:
        keep = np.linspace(0, len(v) - 1, MAX_VISIBLE_POINTS).astype(np.int64)
        v, u = v[keep], u[keep]
    z = view.depth[v, u].astype(np.float64)
    K = view.camera.K
    x = (u - K[0, 2]) / K[0, 0] * z
    y = (v - K[1, 2]) / K[1, 1] * z
    cam = np.stack([x, y, z], axis=1)
    world_from_cam = view.camera.world_from_cam
    return cam @ world_from_cam[:3, :3].T + world_from_cam[:3, 3]


def visible_points(capture: Capture, view: FrameView, instance: int) -> NDArray[np.float64]:
    """The points of ``instance`` that frame ``view`` shows, world frame [n, 3], metres.

    With depth: the frame's masked depth, back-projected. Without: the instance's point cloud P_i
    restricted to the points that project inside its mask in this frame.
    """
    if view.depth is not None:
        return backproject(view, view.mask == instance)
    pts = np.asarray(capture.point_cloud(instance).points, dtype=np.float64)
    if not len(pts):
        return pts.reshape(0, 3)
    uv, z = view.camera.project(pts)
    h, w = view.mask.shape
    ui, vi = np.round(uv[:, 0]).astype(np.int64), np.round(uv[:, 1]).astype(np.int64)
    inside = (z > 0) & (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
    hit = np.zeros(len(pts), bool)
    hit[inside] = view.mask[vi[inside], ui[inside]] == instance
    return pts[hit]
