"""What a capture holds per camera and per instance: cameras, instance labels, instance points."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.records.ids import InstanceId


@dataclass(frozen=True)
class Camera:
    """A calibrated pinhole camera of one frame.

    K: float64 [3, 3] intrinsics in pixels (fx, fy, cx, cy; zero skew).
    world_from_cam: float64 [4, 4] rigid pose, OpenCV camera axes, metres.
    width, height: image size in pixels.
    """

    K: NDArray[np.float64]
    world_from_cam: NDArray[np.float64]
    width: int
    height: int

    @property
    def cam_from_world(self) -> NDArray[np.float64]:
        rot = self.world_from_cam[:3, :3]
        out = np.eye(4)
        out[:3, :3] = rot.T
        out[:3, 3] = -rot.T @ self.world_from_cam[:3, 3]
        return out

    @property
    def center(self) -> NDArray[np.float64]:
        """Camera centre in the world frame, float64 [3], metres."""
        return self.world_from_cam[:3, 3]

    def project(self, points_world: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Project world points [n, 3] -> (pixel coordinates [n, 2] (u right, v down), depth along z [n])."""
        cam_from_world = self.cam_from_world
        pts = np.asarray(points_world, dtype=np.float64) @ cam_from_world[:3, :3].T + cam_from_world[:3, 3]
        z = pts[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = (pts[:, :2] / z[:, None]) * np.diag(self.K)[:2] + self.K[:2, 2]
        return uv, z


@dataclass(frozen=True)
class Instance:
    """One panoptic instance: canonical id, category label, and whether it is structure (floor/wall/ceiling)."""

    id: InstanceId
    label: str
    structural: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"id": int(self.id), "label": self.label, "structural": bool(self.structural)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Instance:
        return cls(InstanceId(int(d["id"])), str(d["label"]), bool(d.get("structural", False)))


@dataclass(frozen=True)
class InstancePoints:
    """The semantic point cloud P_i of one instance.

    points: float32 [n, 3], world frame, metres.
    colors: uint8 [n, 3], RGB.
    """

    instance: InstanceId
    points: NDArray[np.float32]
    colors: NDArray[np.uint8]

    def __len__(self) -> int:
        return int(self.points.shape[0])
