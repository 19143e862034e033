"""The asset-generator protocol and the shared post-processing (watertight check, unit-box normalisation).

A backend turns one chosen view into a mesh in its own frame (the 'generator frame'):

    GeneratorInput:  rgb uint8 [H, W, 3], mask bool [H, W], camera (Camera), depth float32 [H, W] or None
    GeneratorOutput: vertices float64 [v, 3] and faces int64 [f, 3] in the generator frame (any units),
                     metadata (JSON), and optionally world_from_generator_prior [4, 4] when the
                     generator predicts a placement (SAM 3D Objects' layout), which registration may
                     use as its rotation-gate reference.

``finish_asset`` makes the mesh watertight (or says it cannot), normalises it into a centred unit box
(longest side 1) and builds the ``Asset`` with ``asset_from_generator`` recording that normalisation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from rescene_core.geometry import sim3
from rescene_core.records import Asset, Camera, InstanceId


class BackendUnavailable(RuntimeError):
    """A backend cannot load: the message names the extra, file or checkpoint it needs."""


class GenerationFailed(RuntimeError):
    """A backend ran but produced nothing usable for this instance (becomes Missing)."""


@dataclass(frozen=True)
class GeneratorInput:
    """The chosen view of one instance. rgb uint8 [H, W, 3]; mask bool [H, W]; depth float32 [H, W]
    metres along the camera z (0 = invalid) or None; camera: the view's calibrated camera."""

    instance: InstanceId
    label: str
    frame: int
    rgb: NDArray[np.uint8]
    mask: NDArray[np.bool_]
    camera: Camera
    depth: NDArray[np.float32] | None = None


@dataclass(frozen=True)
class GeneratorOutput:
    """A backend's raw mesh in its generator frame, with metadata (JSON types)."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    metadata: dict[str, Any] = field(default_factory=dict)
    world_from_generator_prior: NDArray[np.float64] | None = None


class AssetBackend(Protocol):
    """What an asset generator implements."""

    name: str

    def generate(self, view: GeneratorInput) -> GeneratorOutput:
        """Mesh of ``view``'s object in the generator frame; raises GenerationFailed when it cannot."""
        ...


def unit_box_normalisation(vertices: NDArray[np.float64]) -> sim3.Matrix4:
    """asset_from_generator: bounding-box centre to the origin, longest side to 1."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    side = float((hi - lo).max())
    if not side > 0 or not np.isfinite(side):
        raise GenerationFailed(f"mesh has a degenerate bounding box (longest side {side!r})")
    return sim3.sim3_from_parts(1.0 / side, np.eye(3), -0.5 * (lo + hi) / side)


def finish_asset(instance: InstanceId, backend: str, out: GeneratorOutput) -> Asset:
    """Watertight check/repair, unit-box normalisation, and the Asset record (raises GenerationFailed)."""
    import trimesh

    vertices = np.asarray(out.vertices, dtype=np.float64)
    faces = np.asarray(out.faces, dtype=np.int64)
    if len(faces) == 0 or len(vertices) < 4 or not np.all(np.isfinite(vertices)):
        raise GenerationFailed("backend returned an empty or non-finite mesh")
    mesh = trimesh.Trimesh(vertices, faces, process=True)
    if not mesh.is_watertight:
        trimesh.repair.fill_holes(mesh)
    if not mesh.is_watertight:
        raise GenerationFailed("mesh is not watertight and could not be repaired")
    if mesh.volume < 0:
        mesh.invert()
    asset_from_generator = unit_box_normalisation(np.asarray(mesh.vertices))
    metadata = dict(out.metadata)
    metadata["watertight"] = bool(mesh.is_watertight)
    if out.world_from_generator_prior is not None:
        prior = sim3.compose(out.world_from_generator_prior, sim3.inverse(asset_from_generator))
        metadata["world_from_asset_prior"] = prior.tolist()
    return Asset(
        instance=instance,
        vertices=sim3.apply(asset_from_generator, mesh.vertices),
        faces=np.asarray(mesh.faces, dtype=np.int64),
        backend=backend,
        metadata=metadata,
        asset_from_generator=asset_from_generator,
    )
