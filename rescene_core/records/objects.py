"""Per-instance stage results: the chosen view, the generated asset, the registered pose."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.records.ids import InstanceId


@dataclass(frozen=True)
class ViewChoice:
    """The view HierView (or a baseline) chose for one instance.

    frame: chosen frame index t*. method: the selection method. reason: why this frame.
    candidates: one row per candidate frame with every score computed ({"frame", "area", "bbox_ratio",
    "semantic", "completeness", "stage_reached", ...}).
    """

    instance: InstanceId
    frame: int
    method: str
    reason: str
    candidates: tuple[dict[str, Any], ...] = ()
    semantic_backend: str = "none"

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "frame": int(self.frame),
            "method": self.method,
            "reason": self.reason,
            "semantic_backend": self.semantic_backend,
            "candidates": list(self.candidates),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> ViewChoice:
        return cls(
            InstanceId(int(d["instance"])),
            int(d["frame"]),
            str(d["method"]),
            str(d["reason"]),
            tuple(d.get("candidates", ())),
            str(d.get("semantic_backend", "none")),
        )


@dataclass(frozen=True)
class Asset:
    """A generated mesh in the asset's own normalised frame.

    vertices: float64 [v, 3] in the asset frame (unit bounding box, centred). faces: int64 [f, 3].
    backend: which generator produced it ('lift', 'sam3d', 'gt'). metadata: backend details.
    asset_from_generator: float64 [4, 4] Sim(3) from the generator's raw output frame to the asset frame.
    """

    instance: InstanceId
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    backend: str
    metadata: dict[str, Any] = field(default_factory=dict)
    asset_from_generator: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))


@dataclass(frozen=True)
class Pose:
    """The registered pose T_i of one instance's asset.

    world_from_asset: float64 [4, 4] Sim(3) mapping asset-frame points to world metres.
    method: which solver produced it. diagnostics: residuals, inlier ratios and every gate decision.
    """

    instance: InstanceId
    world_from_asset: NDArray[np.float64]
    method: str
    diagnostics: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "world_from_asset": np.asarray(self.world_from_asset).tolist(),
            "method": self.method,
            "diagnostics": self.diagnostics,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Pose:
        return cls(
            InstanceId(int(d["instance"])),
            np.asarray(d["world_from_asset"], dtype=np.float64),
            str(d["method"]),
            dict(d.get("diagnostics", {})),
        )
