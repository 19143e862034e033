"""The primitives the object categories are built from: parts, supports, the watertight union of parts
(manifold3d), and the palettes they draw colours from. Metres, z up (see ``objects``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import manifold3d
import numpy as np
from numpy.typing import NDArray

from rescene_core.render import Texture


@dataclass
class Part:
    """One primitive of an object: vertices float64 [v, 3] (canonical frame), faces int64 [f, 3]."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    color: tuple[float, float, float]
    texture: int


@dataclass(frozen=True)
class Support:
    """A horizontal surface other objects may rest on: rectangle in the canonical frame, top height,
    free height above it (m)."""

    x0: float
    x1: float
    y0: float
    y1: float
    z: float
    clearance: float


@dataclass
class ObjectModel:
    """An object before placement: parts, support surfaces, and its bounding box (canonical frame)."""

    label: str
    parts: list[Part]
    supports: list[Support] = field(default_factory=list)
    bounds: NDArray[np.float64] = field(default_factory=lambda: np.zeros((2, 3)))
    _union: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None

    @property
    def size(self) -> NDArray[np.float64]:
        """Bounding-box extents (x, y, z) in metres."""
        return self.bounds[1] - self.bounds[0]

    def union_mesh(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The watertight union of the parts: vertices float64 [v, 3], faces int64 [f, 3]."""
        if self._union is None:
            solids = [_manifold(p.vertices, p.faces) for p in self.parts]
            mesh = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add).to_mesh()
            self._union = (
                np.asarray(mesh.vert_properties[:, :3], np.float64),
                np.asarray(mesh.tri_verts, np.int64),
            )
        return self._union


def _manifold(vertices: NDArray, faces: NDArray) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh(vert_properties=np.asarray(vertices, np.float32), tri_verts=np.asarray(faces, np.uint32))
    )


def _mesh_of(solid: manifold3d.Manifold) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    m = solid.to_mesh()
    return np.asarray(m.vert_properties[:, :3], np.float64), np.asarray(m.tri_verts, np.int64)


class Builder:
    """Collects parts and support surfaces of one object (coordinates in the canonical frame)."""

    def __init__(self, label: str):
        self.label = label
        self.parts: list[Part] = []
        self.supports: list[Support] = []

    def _add(self, solid: manifold3d.Manifold, color, texture: int) -> None:
        v, f = _mesh_of(solid)
        self.parts.append(Part(v, f, tuple(float(c) for c in color), int(texture)))

    def box(self, x0, x1, y0, y1, z0, z1, color, texture=Texture.PLAIN) -> None:
        solid = manifold3d.Manifold.cube((x1 - x0, y1 - y0, z1 - z0)).translate((x0, y0, z0))
        self._add(solid, color, texture)

    def cylinder(self, cx, cy, z0, z1, r0, r1=None, color=(0.5, 0.5, 0.5), texture=Texture.PLAIN, segments=20):
        """A vertical cylinder or frustum (radius r0 at z0, r1 at z1)."""
        solid = manifold3d.Manifold.cylinder(z1 - z0, r0, r0 if r1 is None else r1, segments).translate((cx, cy, z0))
        self._add(solid, color, texture)

    def disc_y(self, cx, cz, y0, y1, r, color, texture=Texture.PLAIN, segments=28):
        """A cylinder whose axis is the y axis (a wall clock's face), from y0 to y1, centre (cx, cz)."""
        solid = manifold3d.Manifold.cylinder(y1 - y0, r, r, segments)
        solid = solid.rotate((-90.0, 0.0, 0.0)).translate((cx, y0, cz))
        self._add(solid, color, texture)

    def sphere(self, cx, cy, cz, r, color, texture=Texture.PLAIN, segments=14, squash=1.0):
        solid = manifold3d.Manifold.sphere(r, segments).scale((1.0, 1.0, squash)).translate((cx, cy, cz))
        self._add(solid, color, texture)

    def support(self, x0, x1, y0, y1, z, clearance) -> None:
        self.supports.append(Support(x0, x1, y0, y1, z, clearance))

    def build(self) -> ObjectModel:
        """Recentre so the origin is the bottom centre of the bounding box, and return the model."""
        allv = np.concatenate([p.vertices for p in self.parts])
        lo, hi = allv.min(0), allv.max(0)
        shift = -np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
        parts = [Part(p.vertices + shift, p.faces, p.color, p.texture) for p in self.parts]
        sx, sy, sz = shift
        supports = [Support(s.x0 + sx, s.x1 + sx, s.y0 + sy, s.y1 + sy, s.z + sz, s.clearance) for s in self.supports]
        return ObjectModel(self.label, parts, supports, np.stack([lo + shift, hi + shift]))


# ---- colours -------------------------------------------------------------------------------------------

WOODS = ((0.55, 0.38, 0.24), (0.68, 0.5, 0.33), (0.42, 0.28, 0.18), (0.78, 0.64, 0.46), (0.32, 0.22, 0.15))
PAINTED = ((0.92, 0.92, 0.9), (0.25, 0.27, 0.3), (0.55, 0.62, 0.58), (0.7, 0.72, 0.76), (0.85, 0.8, 0.7))
FABRICS = (
    (0.35, 0.42, 0.55),
    (0.55, 0.3, 0.28),
    (0.45, 0.5, 0.38),
    (0.62, 0.58, 0.52),
    (0.3, 0.3, 0.33),
    (0.72, 0.6, 0.4),
    (0.4, 0.33, 0.48),
)
BOOKS = (
    (0.7, 0.15, 0.12),
    (0.12, 0.3, 0.55),
    (0.15, 0.45, 0.25),
    (0.85, 0.7, 0.2),
    (0.9, 0.88, 0.82),
    (0.2, 0.2, 0.22),
    (0.55, 0.2, 0.45),
)
METAL = (0.62, 0.63, 0.65)
BLACK = (0.08, 0.08, 0.09)
WHITE = (0.93, 0.93, 0.9)


def _pick(rng: np.random.Generator, options, jitter: float = 0.05) -> tuple[float, float, float]:
    base = np.asarray(options[int(rng.integers(len(options)))], np.float64)
    return tuple(np.clip(base * (1 + rng.uniform(-jitter, jitter, 3)), 0, 1))


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _legs(b: Builder, x: float, y: float, z1: float, t: float, color, texture=Texture.WOOD) -> None:
    """Four square legs of side t whose outer faces are at |x|, |y|, from the floor to z1."""
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (x - t / 2), sy * (y - t / 2)
            b.box(cx - t / 2, cx + t / 2, cy - t / 2, cy + t / 2, 0.0, z1, color, texture)
