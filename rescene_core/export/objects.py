"""The record every exporter takes: one placed object (mesh in its asset frame plus its world pose)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.records import Completion


@dataclass(frozen=True)
class ExportObject:
    """One object to export.

    vertices: float64 [v, 3] in the asset frame. faces: int64 [f, 3].
    world_from_asset: float64 [4, 4] Sim(3), the final (attached) pose.
    registered_world_from_asset: float64 [4, 4], the pose before attachment, when known.
    completions: geometry attachment added from the object's observed points (shelf boards, a base), in
      the asset frame; the simulation exports add them as colliders.
    """

    instance: int
    label: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    world_from_asset: NDArray[np.float64]
    registered_world_from_asset: NDArray[np.float64] | None = None
    completions: tuple[Completion, ...] = ()

    @property
    def node_name(self) -> str:
        return node_name(self.instance, self.label)


def node_name(instance: int, label: str) -> str:
    """Scene node name of an object: ``obj_<id>_<label>`` (label spaces become underscores)."""
    return f"obj_{int(instance)}_{label.replace(' ', '_')}"
