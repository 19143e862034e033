"""The record every exporter takes: one placed object (mesh in its asset frame plus its world pose)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from rescene_core.geometry.completion import cut_mesh
from rescene_core.names import node_name
from rescene_core.records import Completion, CompletionKind, InstanceId, Layout


@dataclass(frozen=True)
class ExportObject:
    """One object to export.

    vertices: float64 [v, 3] in the asset frame. faces: int64 [f, 3].
    world_from_asset: float64 [4, 4] Sim(3), the final (attached) pose.
    registered_world_from_asset: float64 [4, 4], the pose before attachment, when known.
    completions: geometry attachment added from the object's observed points (shelf boards, a base), in
      the asset frame; the simulation exports add them as colliders. Cuts are not among them: they are
      applied to ``vertices`` / ``faces`` already (``placed_object``).
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
        """The object's name in every export (rescene_core/names.py)."""
        return node_name(self.instance, self.label)


def placed_object(
    instance: int,
    label: str,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    world_from_asset: NDArray[np.float64],
    registered_world_from_asset: NDArray[np.float64] | None,
    completions: tuple[Completion, ...] | list[Completion] = (),
) -> ExportObject:
    """The ExportObject of a placed asset and the completions attachment gave it: the mesh cut at its cut
    planes (what everyone sees), the other completions carried for the simulation exports."""

    cuts = [c for c in completions if c.kind is CompletionKind.CUT]
    if cuts:
        vertices, faces = cut_mesh(vertices, faces, cuts)
    return ExportObject(
        int(instance),
        label,
        np.asarray(vertices, np.float64),
        np.asarray(faces, np.int64),
        np.asarray(world_from_asset, np.float64),
        registered_world_from_asset,
        tuple(c for c in completions if c.kind is not CompletionKind.CUT),
    )


class RegisteredObject(Protocol):
    """What ``placed_objects`` reads of an object: its asset-frame mesh and its registered pose."""

    @property
    def instance(self) -> int: ...
    @property
    def label(self) -> str: ...
    @property
    def vertices(self) -> NDArray[np.float64]: ...
    @property
    def faces(self) -> NDArray[np.int64]: ...
    @property
    def world_from_asset(self) -> NDArray[np.float64]: ...


def placed_objects(objects: Iterable[RegisteredObject], layout: Layout | None) -> list[ExportObject]:
    """The ExportObjects of registered ``objects`` at their ``layout`` poses (the registered pose for an
    object the layout did not place, or without a layout), each with the completions attachment gave it
    (``placed_object``)."""
    completions = layout.completions() if layout is not None else {}
    poses = layout.world_from_asset if layout is not None else {}
    return [
        placed_object(
            o.instance,
            o.label,
            o.vertices,
            o.faces,
            poses.get(InstanceId(int(o.instance)), o.world_from_asset),
            o.world_from_asset,
            tuple(completions.get(InstanceId(int(o.instance)), ())),
        )
        for o in objects
    ]
