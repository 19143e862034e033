"""Object categories built from primitives with real-world proportions.

Every builder returns an ``ObjectModel`` in the object's canonical frame: metres, origin at the centre of
the bottom face of its bounding box, z up, the front faces +y and the back is at min y. Parts keep their
own colour and texture for rendering; the ground-truth mesh is the watertight union of the parts.
"""

from __future__ import annotations

from collections.abc import Callable
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


# ---- categories --------------------------------------------------------------------------------------------


def bed(rng: np.random.Generator) -> ObjectModel:
    b = Builder("bed")
    w = float(rng.choice([0.95, 1.45, 1.65, 1.85])) + _u(rng, -0.03, 0.03)
    length, wood = _u(rng, 2.0, 2.12), _pick(rng, WOODS)
    y0, y1 = -length / 2, length / 2
    head_h = _u(rng, 0.85, 1.15)
    b.box(-w / 2, w / 2, y0, y0 + 0.06, 0.0, head_h, wood, Texture.WOOD)
    _legs(b, w / 2, length / 2, 0.1, 0.07, wood)
    b.box(-w / 2, w / 2, y0 + 0.06, y1, 0.1, 0.3, wood, Texture.WOOD)
    b.box(-w / 2 + 0.02, w / 2 - 0.02, y0 + 0.07, y1 - 0.02, 0.3, 0.52, WHITE, Texture.FABRIC)
    cover = _pick(rng, FABRICS)
    b.box(-w / 2 + 0.01, w / 2 - 0.01, y0 + _u(rng, 0.6, 0.8), y1 - 0.01, 0.5, 0.56, cover, Texture.FABRIC)
    n_pillows = 1 if w < 1.2 else 2
    pw = (w - 0.16) / n_pillows
    pillow = _pick(rng, (WHITE, (0.85, 0.82, 0.75)) + FABRICS[:2], 0.03)
    for k in range(n_pillows):
        x0 = -w / 2 + 0.08 + k * pw
        b.box(x0 + 0.02, x0 + pw - 0.02, y0 + 0.12, y0 + 0.52, 0.52, 0.64, pillow, Texture.FABRIC)
    return b.build()


def nightstand(rng: np.random.Generator) -> ObjectModel:
    b = Builder("nightstand")
    w, d, h = _u(rng, 0.42, 0.55), _u(rng, 0.36, 0.45), _u(rng, 0.5, 0.62)
    col = _pick(rng, WOODS + PAINTED[:2])
    _legs(b, w / 2, d / 2, 0.08, 0.04, col)
    b.box(-w / 2, w / 2, -d / 2, d / 2, 0.08, h, col, Texture.WOOD)
    front = tuple(np.clip(np.asarray(col) * 1.12, 0, 1))
    n = int(rng.integers(1, 3))
    dh = (h - 0.12) / n
    for k in range(n):
        z0 = 0.1 + k * dh
        b.box(-w / 2 + 0.02, w / 2 - 0.02, d / 2, d / 2 + 0.015, z0 + 0.01, z0 + dh - 0.01, front, Texture.WOOD)
        b.box(-0.05, 0.05, d / 2 + 0.015, d / 2 + 0.03, z0 + dh / 2 - 0.01, z0 + dh / 2 + 0.01, METAL)
    b.support(-w / 2 + 0.03, w / 2 - 0.03, -d / 2 + 0.03, d / 2 - 0.03, h, 0.9)
    return b.build()


def wardrobe(rng: np.random.Generator) -> ObjectModel:
    b = Builder("wardrobe")
    w, d, h = _u(rng, 0.9, 1.6), _u(rng, 0.55, 0.62), _u(rng, 1.9, 2.15)
    col = _pick(rng, WOODS + PAINTED)
    b.box(-w / 2, w / 2, -d / 2, d / 2 - 0.02, 0.0, h, col, Texture.WOOD)
    n = 2 if w < 1.25 else 3
    dw = (w - 0.02) / n
    front = tuple(np.clip(np.asarray(col) * 1.08, 0, 1))
    for k in range(n):
        x0 = -w / 2 + 0.01 + k * dw
        b.box(x0 + 0.004, x0 + dw - 0.004, d / 2 - 0.02, d / 2, 0.08, h - 0.03, front, Texture.WOOD)
        hx = x0 + dw - 0.06 if k % 2 == 0 else x0 + 0.06
        b.box(hx - 0.01, hx + 0.01, d / 2, d / 2 + 0.025, h * 0.45, h * 0.45 + 0.3, METAL)
    return b.build()


def cabinet(rng: np.random.Generator) -> ObjectModel:
    b = Builder("cabinet")
    w, d, h = _u(rng, 0.8, 1.6), _u(rng, 0.4, 0.48), _u(rng, 0.7, 0.9)
    col = _pick(rng, WOODS + PAINTED)
    _legs(b, w / 2 - 0.03, d / 2 - 0.03, 0.12, 0.04, METAL, Texture.PLAIN)
    b.box(-w / 2, w / 2, -d / 2, d / 2 - 0.015, 0.12, h, col, Texture.WOOD)
    n = max(2, int(round(w / 0.45)))
    dw = (w - 0.02) / n
    front = tuple(np.clip(np.asarray(col) * 0.9, 0, 1))
    for k in range(n):
        x0 = -w / 2 + 0.01 + k * dw
        b.box(x0 + 0.004, x0 + dw - 0.004, d / 2 - 0.015, d / 2, 0.14, h - 0.02, front, Texture.WOOD)
        b.box(x0 + dw / 2 - 0.04, x0 + dw / 2 + 0.04, d / 2, d / 2 + 0.02, h - 0.08, h - 0.065, METAL)
    b.support(-w / 2 + 0.03, w / 2 - 0.03, -d / 2 + 0.03, d / 2 - 0.04, h, 0.8)
    return b.build()


def desk(rng: np.random.Generator) -> ObjectModel:
    b = Builder("desk")
    w, d, h = _u(rng, 1.1, 1.6), _u(rng, 0.6, 0.75), _u(rng, 0.73, 0.77)
    top = _pick(rng, WOODS + PAINTED[:1])
    frame = _pick(rng, (METAL, BLACK) + WOODS[2:3])
    b.box(-w / 2, w / 2, -d / 2, d / 2, h - 0.03, h, top, Texture.WOOD)
    _legs(b, w / 2 - 0.02, d / 2 - 0.02, h - 0.03, 0.05, frame, Texture.PLAIN)
    if rng.uniform() < 0.5:
        side = 1 if rng.uniform() < 0.5 else -1
        xa, xb = sorted((side * (w / 2 - 0.08), side * (w / 2 - 0.5)))
        b.box(xa, xb, -d / 2 + 0.05, d / 2 - 0.04, 0.05, h - 0.03, top, Texture.WOOD)
    b.box(-w / 2 + 0.07, w / 2 - 0.07, -d / 2 + 0.02, -d / 2 + 0.04, h - 0.2, h - 0.03, frame)
    b.support(-w / 2 + 0.03, w / 2 - 0.03, -d / 2 + 0.03, d / 2 - 0.03, h, 0.9)
    return b.build()


def chair(rng: np.random.Generator) -> ObjectModel:
    b = Builder("chair")
    w, d, seat = _u(rng, 0.42, 0.5), _u(rng, 0.42, 0.5), _u(rng, 0.44, 0.48)
    col = _pick(rng, WOODS + (BLACK,))
    cushion = _pick(rng, FABRICS)
    t = _u(rng, 0.03, 0.04)
    _legs(b, w / 2, d / 2, seat - 0.04, t, col)
    b.box(-w / 2, w / 2, -d / 2, d / 2, seat - 0.04, seat, col, Texture.WOOD)
    b.box(-w / 2 + 0.02, w / 2 - 0.02, -d / 2 + 0.03, d / 2 - 0.02, seat, seat + 0.03, cushion, Texture.FABRIC)
    top = seat + _u(rng, 0.38, 0.48)
    for sx in (-1, 1):
        cx = sx * (w / 2 - t / 2)
        b.box(cx - t / 2, cx + t / 2, -d / 2, -d / 2 + t, seat, top, col, Texture.WOOD)
    b.box(-w / 2 + t, w / 2 - t, -d / 2, -d / 2 + 0.025, top - 0.2, top - 0.02, col, Texture.WOOD)
    return b.build()


def dining_table(rng: np.random.Generator) -> ObjectModel:
    b = Builder("dining table")
    w, d, h = _u(rng, 1.2, 1.8), _u(rng, 0.8, 1.0), _u(rng, 0.73, 0.77)
    col = _pick(rng, WOODS)
    b.box(-w / 2, w / 2, -d / 2, d / 2, h - 0.04, h, col, Texture.WOOD)
    _legs(b, w / 2 - 0.05, d / 2 - 0.05, h - 0.04, 0.07, col)
    b.box(-w / 2 + 0.1, w / 2 - 0.1, -d / 2 + 0.08, d / 2 - 0.08, h - 0.12, h - 0.04, col, Texture.WOOD)
    b.support(-w / 2 + 0.04, w / 2 - 0.04, -d / 2 + 0.04, d / 2 - 0.04, h, 1.0)
    return b.build()


def sofa(rng: np.random.Generator) -> ObjectModel:
    b = Builder("sofa")
    w, d = _u(rng, 1.7, 2.3), _u(rng, 0.85, 0.95)
    back_h, seat, arm = _u(rng, 0.78, 0.9), _u(rng, 0.4, 0.45), _u(rng, 0.58, 0.66)
    fab = _pick(rng, FABRICS)
    _legs(b, w / 2 - 0.04, d / 2 - 0.04, 0.08, 0.05, WOODS[2])
    b.box(-w / 2, w / 2, -d / 2, d / 2, 0.08, seat - 0.08, fab, Texture.FABRIC)
    b.box(-w / 2, w / 2, -d / 2, -d / 2 + 0.2, seat - 0.08, back_h, fab, Texture.FABRIC)
    for sx in (-1, 1):
        xa, xb = sorted((sx * w / 2, sx * (w / 2 - 0.18)))
        b.box(xa, xb, -d / 2, d / 2, seat - 0.08, arm, fab, Texture.FABRIC)
    n = 2 if w < 2.0 else 3
    inner = w - 0.36
    cw = inner / n
    lighter = tuple(np.clip(np.asarray(fab) * 1.1, 0, 1))
    for k in range(n):
        x0 = -w / 2 + 0.18 + k * cw
        b.box(x0 + 0.005, x0 + cw - 0.005, -d / 2 + 0.2, d / 2 - 0.01, seat - 0.08, seat, lighter, Texture.FABRIC)
        b.box(x0 + 0.02, x0 + cw - 0.02, -d / 2 + 0.2, -d / 2 + 0.32, seat, back_h - 0.05, lighter, Texture.FABRIC)
    return b.build()


def bookshelf(rng: np.random.Generator) -> ObjectModel:
    b = Builder("bookshelf")
    w, d, h = _u(rng, 0.7, 1.0), _u(rng, 0.28, 0.35), _u(rng, 1.6, 2.0)
    t, col = 0.02, _pick(rng, WOODS + PAINTED[:2])
    b.box(-w / 2, -w / 2 + t, -d / 2, d / 2, 0.0, h, col, Texture.WOOD)
    b.box(w / 2 - t, w / 2, -d / 2, d / 2, 0.0, h, col, Texture.WOOD)
    b.box(-w / 2 + t, w / 2 - t, -d / 2, -d / 2 + 0.01, 0.0, h, col, Texture.WOOD)
    b.box(-w / 2 + t, w / 2 - t, -d / 2, d / 2, h - t, h, col, Texture.WOOD)
    b.box(-w / 2 + t, w / 2 - t, -d / 2, d / 2, 0.0, 0.07, col, Texture.WOOD)
    n = int(rng.integers(4, 6))
    cell = (h - t - 0.07) / n
    tops = [0.07 + k * cell for k in range(n)]
    for z in tops[1:]:
        b.box(-w / 2 + t, w / 2 - t, -d / 2 + 0.01, d / 2, z - t, z, col, Texture.WOOD)
    decorated = set(rng.choice(n, size=max(1, n // 2), replace=False).tolist())
    for k, z in enumerate(tops):
        clear = cell - t
        if k in decorated:
            x = -w / 2 + t + 0.005
            end = w / 2 - t - _u(rng, 0.05, 0.3)
            while x < end - 0.02:
                bw = _u(rng, 0.018, 0.045)
                bh = min(clear - 0.02, _u(rng, 0.16, 0.3))
                bd = min(d - 0.04, _u(rng, 0.15, 0.24))
                b.box(x, min(x + bw, end), -d / 2 + 0.012, -d / 2 + 0.012 + bd, z, z + bh, _pick(rng, BOOKS))
                x += bw + 0.001
        else:
            b.support(-w / 2 + t + 0.01, w / 2 - t - 0.01, -d / 2 + 0.02, d / 2 - 0.01, z, clear - 0.01)
    return b.build()


def floor_lamp(rng: np.random.Generator) -> ObjectModel:
    b = Builder("floor lamp")
    base, h = _u(rng, 0.12, 0.16), _u(rng, 1.45, 1.75)
    col = _pick(rng, (BLACK, METAL, (0.7, 0.6, 0.35)))
    b.cylinder(0, 0, 0.0, 0.03, base, color=col)
    b.cylinder(0, 0, 0.03, h - 0.25, 0.012, color=col, segments=10)
    shade = _pick(rng, ((0.95, 0.9, 0.78), WHITE, (0.85, 0.75, 0.6)))
    r = _u(rng, 0.17, 0.23)
    b.cylinder(0, 0, h - 0.3, h, r, r * 0.7, color=shade, texture=Texture.FABRIC, segments=24)
    return b.build()


def table_lamp(rng: np.random.Generator) -> ObjectModel:
    b = Builder("table lamp")
    r, h = _u(rng, 0.06, 0.085), _u(rng, 0.38, 0.52)
    col = _pick(rng, ((0.8, 0.78, 0.72), BLACK, (0.6, 0.35, 0.25), METAL))
    b.cylinder(0, 0, 0.0, 0.03, r, color=col)
    b.cylinder(0, 0, 0.03, h - 0.18, 0.012, color=col, segments=10)
    shade = _pick(rng, ((0.95, 0.9, 0.78), WHITE, (0.7, 0.8, 0.75)))
    sr = _u(rng, 0.11, 0.15)
    b.cylinder(0, 0, h - 0.2, h, sr, sr * 0.7, color=shade, texture=Texture.FABRIC, segments=24)
    return b.build()


def monitor(rng: np.random.Generator) -> ObjectModel:
    b = Builder("monitor")
    w = _u(rng, 0.5, 0.64)
    h = w * _u(rng, 0.56, 0.62)
    b.box(-0.11, 0.11, -0.09, 0.07, 0.0, 0.015, BLACK)
    b.box(-0.025, 0.025, -0.06, -0.03, 0.015, 0.14, BLACK)
    b.box(-w / 2, w / 2, -0.03, 0.0, 0.1, 0.1 + h, BLACK)
    b.box(-w / 2 + 0.012, w / 2 - 0.012, 0.0, 0.003, 0.112, 0.1 + h - 0.012, (0.2, 0.3, 0.45), Texture.SCREEN)
    return b.build()


def book_stack(rng: np.random.Generator, fit: tuple[float, float] | None = None) -> ObjectModel:
    """A stack of 2-5 books; ``fit`` = (width, depth) it must fit in (to stack it on another stack)."""
    b = Builder("book stack")
    n = int(rng.integers(2, 6))
    w0, d0 = _u(rng, 0.15, 0.23), _u(rng, 0.2, 0.28)
    if fit is not None:
        w0, d0 = min(w0, fit[0] * 0.8), min(d0, fit[1] * 0.8)
    z = 0.0
    for _ in range(n):
        w, d = w0 * _u(rng, 0.8, 1.0), d0 * _u(rng, 0.8, 1.0)
        dx, dy = _u(rng, -0.015, 0.015), _u(rng, -0.015, 0.015)
        t = _u(rng, 0.018, 0.045)
        b.box(dx - w / 2, dx + w / 2, dy - d / 2, dy + d / 2, z, z + t, _pick(rng, BOOKS))
        z += t
    b.support(-w0 * 0.4, w0 * 0.4, -d0 * 0.4, d0 * 0.4, z, 0.5)
    return b.build()


def potted_plant(rng: np.random.Generator, small: bool = False) -> ObjectModel:
    b = Builder("potted plant")
    if small:
        r, ph, fr = _u(rng, 0.05, 0.075), _u(rng, 0.08, 0.12), _u(rng, 0.07, 0.1)
    else:
        r, ph, fr = _u(rng, 0.12, 0.18), _u(rng, 0.25, 0.38), _u(rng, 0.18, 0.28)
    pot = _pick(rng, ((0.7, 0.4, 0.28), WHITE, (0.25, 0.25, 0.27), (0.5, 0.55, 0.6)))
    b.cylinder(0, 0, 0.0, ph, r * 0.8, r, color=pot, segments=20)
    green = _pick(rng, ((0.2, 0.45, 0.18), (0.28, 0.5, 0.22), (0.15, 0.38, 0.2)), 0.08)
    stem = ph + fr * (1.2 if not small else 0.6)
    b.cylinder(0, 0, ph - 0.01, stem, r * 0.12, color=(0.35, 0.28, 0.18), segments=8)
    n = int(rng.integers(3, 6))
    for k in range(n):
        a = 2 * np.pi * k / n + _u(rng, -0.3, 0.3)
        rr = fr * _u(rng, 0.7, 1.0)
        off = fr * 0.5
        cz = stem + _u(rng, -0.3, 0.5) * fr
        b.sphere(off * np.cos(a), off * np.sin(a), cz, rr, green, Texture.FOLIAGE, squash=_u(rng, 0.8, 1.2))
    return b.build()


def small_plant(rng: np.random.Generator) -> ObjectModel:
    return potted_plant(rng, small=True)


def picture(rng: np.random.Generator) -> ObjectModel:
    b = Builder("picture")
    w, h = _u(rng, 0.35, 0.9), _u(rng, 0.3, 0.7)
    d, f = 0.025, _u(rng, 0.02, 0.05)
    frame = _pick(rng, WOODS + (BLACK, WHITE, (0.75, 0.62, 0.3)))
    b.box(-w / 2, w / 2, -d / 2, d / 2 - 0.008, 0.0, h, frame, Texture.WOOD)
    for xa, xb, za, zb in (
        (-w / 2, w / 2, 0, f),
        (-w / 2, w / 2, h - f, h),
        (-w / 2, -w / 2 + f, 0, h),
        (w / 2 - f, w / 2, 0, h),
    ):
        b.box(xa, xb, -d / 2, d / 2, za, zb, frame, Texture.WOOD)
    canvas = _pick(rng, ((0.8, 0.6, 0.4), (0.4, 0.6, 0.8), (0.6, 0.75, 0.5), (0.85, 0.75, 0.6)))
    b.box(-w / 2 + f, w / 2 - f, -d / 2, d / 2 - 0.005, f, h - f, canvas, Texture.PAINTING)
    return b.build()


def tv(rng: np.random.Generator) -> ObjectModel:
    b = Builder("TV")
    w = _u(rng, 0.95, 1.45)
    h, d = w * 0.58, 0.05
    b.box(-w / 2, w / 2, -d / 2, d / 2 - 0.003, 0.0, h, BLACK)
    b.box(-w / 2 + 0.015, w / 2 - 0.015, d / 2 - 0.003, d / 2, 0.015, h - 0.015, (0.1, 0.12, 0.16), Texture.SCREEN)
    return b.build()


def wall_clock(rng: np.random.Generator) -> ObjectModel:
    b = Builder("wall clock")
    r = _u(rng, 0.12, 0.18)
    rim = _pick(rng, (BLACK, WOODS[0], METAL, (0.7, 0.2, 0.15)))
    b.disc_y(0.0, r, -0.02, 0.02, r, rim)
    b.disc_y(0.0, r, 0.02, 0.024, r * 0.88, WHITE)
    b.box(-0.005, 0.005, 0.024, 0.03, r, r + 0.75 * r, BLACK)
    b.box(0.0, 0.55 * r, 0.024, 0.03, r - 0.006, r + 0.006, BLACK)
    return b.build()


def mirror(rng: np.random.Generator) -> ObjectModel:
    b = Builder("mirror")
    w, h, d, f = _u(rng, 0.45, 0.7), _u(rng, 0.8, 1.4), 0.025, 0.035
    frame = _pick(rng, WOODS + (BLACK, (0.75, 0.62, 0.3)))
    for xa, xb, za, zb in (
        (-w / 2, w / 2, 0, f),
        (-w / 2, w / 2, h - f, h),
        (-w / 2, -w / 2 + f, 0, h),
        (w / 2 - f, w / 2, 0, h),
    ):
        b.box(xa, xb, -d / 2, d / 2, za, zb, frame, Texture.WOOD)
    b.box(-w / 2 + f, w / 2 - f, -d / 2, d / 2 - 0.006, f, h - f, (0.72, 0.8, 0.84), Texture.SCREEN)
    return b.build()


def wall_shelf(rng: np.random.Generator) -> ObjectModel:
    b = Builder("wall shelf")
    w, d = _u(rng, 0.6, 1.0), _u(rng, 0.2, 0.26)
    col = _pick(rng, WOODS + PAINTED[:1])
    bracket = _pick(rng, (BLACK, METAL))
    for sx in (-1, 1):
        cx = sx * w * 0.33
        b.box(cx - 0.01, cx + 0.01, -d / 2, d / 2 - 0.04, 0.0, 0.14, bracket)
    b.box(-w / 2, w / 2, -d / 2, d / 2, 0.14, 0.17, col, Texture.WOOD)
    b.support(-w / 2 + 0.02, w / 2 - 0.02, -d / 2 + 0.02, d / 2 - 0.02, 0.17, 0.35)
    return b.build()


# ---- kitchen (the egocentric preset) -------------------------------------------------------------------

STONE = ((0.86, 0.85, 0.82), (0.3, 0.3, 0.32), (0.72, 0.68, 0.6), (0.93, 0.93, 0.92))
"""Worktop colours: light stone, dark stone, sand, white."""
CERAMIC = (WHITE, (0.82, 0.35, 0.25), (0.3, 0.45, 0.65), (0.85, 0.78, 0.55), (0.35, 0.55, 0.45), (0.2, 0.2, 0.22))


def _front_panels(b: Builder, x0: float, x1: float, y: float, z0: float, z1: float, n: int, col, handle_z) -> None:
    """``n`` door or drawer fronts across [x0, x1] on the face at ``y`` (1.5 cm proud of it), a handle on each
    at height ``handle_z`` (None: a handle near the bottom of each front)."""
    dw = (x1 - x0) / n
    for k in range(n):
        a = x0 + k * dw
        b.box(a + 0.003, a + dw - 0.003, y, y + 0.015, z0, z1, col, Texture.WOOD)
        hz = z0 + 0.06 if handle_z is None else handle_z
        b.box(a + dw / 2 - 0.05, a + dw / 2 + 0.05, y + 0.015, y + 0.03, hz - 0.008, hz + 0.008, METAL)


def kitchen_island(rng: np.random.Generator) -> ObjectModel:
    """A closed block about 0.9 m high: a plinth, a cabinet body with doors on its front (+y), and a worktop
    that overhangs the back by 15-25 cm (where bar stools stand)."""
    b = Builder("kitchen island")
    w, d, h = _u(rng, 1.5, 2.2), _u(rng, 0.85, 1.05), _u(rng, 0.89, 0.94)
    overhang = _u(rng, 0.15, 0.25)
    body = _pick(rng, PAINTED + WOODS[:2])
    top = _pick(rng, STONE, 0.03)
    y0, y1 = -d / 2, d / 2
    b.box(-w / 2 + 0.06, w / 2 - 0.06, y0 + overhang + 0.06, y1 - 0.08, 0.0, 0.1, BLACK)
    b.box(-w / 2 + 0.02, w / 2 - 0.02, y0 + overhang, y1 - 0.05, 0.1, h - 0.04, body, Texture.WOOD)
    n = max(2, int(round((w - 0.04) / 0.5)))
    _front_panels(b, -w / 2 + 0.02, w / 2 - 0.02, y1 - 0.05, 0.11, h - 0.05, n, body, h - 0.12)
    b.box(-w / 2, w / 2, y0, y1, h - 0.04, h, top)
    b.support(-w / 2 + 0.04, w / 2 - 0.04, y0 + 0.04, y1 - 0.04, h, 1.2)
    return b.build()


def kitchen_counter(
    rng: np.random.Generator, width: float | None = None, height: float | None = None, clearance: float = 0.5
) -> ObjectModel:
    """A base unit of a kitchen run, its back to the wall: plinth, doors, a worktop 3 cm proud of the doors.

    width, height: the unit's (m; drawn when None); clearance: free height above the worktop (m), up to
    the upper cabinets."""
    b = Builder("kitchen counter")
    w = _u(rng, 0.6, 1.2) if width is None else width
    h = _u(rng, 0.88, 0.92) if height is None else height
    d = _u(rng, 0.6, 0.64)
    body = _pick(rng, PAINTED + WOODS[:2])
    y0, y1 = -d / 2, d / 2
    b.box(-w / 2 + 0.005, w / 2 - 0.005, y0, y1 - 0.1, 0.0, 0.1, BLACK)
    b.box(-w / 2 + 0.005, w / 2 - 0.005, y0, y1 - 0.05, 0.1, h - 0.04, body, Texture.WOOD)
    _front_panels(b, -w / 2 + 0.005, w / 2 - 0.005, y1 - 0.05, 0.11, h - 0.05, max(1, int(round(w / 0.5))), body, None)
    b.box(-w / 2, w / 2, y0, y1, h - 0.04, h, _pick(rng, STONE, 0.03))
    b.support(-w / 2 + 0.03, w / 2 - 0.03, y0 + 0.03, y1 - 0.04, h, clearance)
    return b.build()


def upper_cabinet(rng: np.random.Generator, width: float | None = None, height: float | None = None) -> ObjectModel:
    """A wall cabinet hung above a kitchen run (label as panoptic models give it: "cabinet/wardrobe part")."""
    b = Builder("cabinet/wardrobe part")
    w = _u(rng, 0.6, 1.0) if width is None else width
    h = _u(rng, 0.6, 0.75) if height is None else height
    d = _u(rng, 0.32, 0.36)
    col = _pick(rng, PAINTED + WOODS[:2])
    b.box(-w / 2, w / 2, -d / 2, d / 2 - 0.02, 0.0, h, col, Texture.WOOD)
    n = max(1, int(round(w / 0.45)))
    dw = w / n
    for k in range(n):
        a = -w / 2 + k * dw
        b.box(a + 0.003, a + dw - 0.003, d / 2 - 0.02, d / 2 - 0.002, 0.005, h - 0.005, col, Texture.WOOD)
        b.box(a + dw / 2 - 0.04, a + dw / 2 + 0.04, d / 2 - 0.002, d / 2, 0.04, 0.055, METAL)
    return b.build()


def bowl(rng: np.random.Generator) -> ObjectModel:
    """A bowl: a frustum wider at the top, a rim band in another glaze."""
    b = Builder("bowl")
    r0, r1, h = _u(rng, 0.035, 0.05), _u(rng, 0.06, 0.1), _u(rng, 0.045, 0.08)
    col = _pick(rng, CERAMIC)
    b.cylinder(0, 0, 0.0, h * 0.85, r0, r0 + (r1 - r0) * 0.85, color=col, segments=24)
    b.cylinder(0, 0, h * 0.85, h, r0 + (r1 - r0) * 0.85, r1, color=_pick(rng, CERAMIC), segments=24)
    return b.build()


def coffee_cup(rng: np.random.Generator) -> ObjectModel:
    """A cup with a handle, under 10 cm in every direction."""
    b = Builder("coffee cup")
    r, h = _u(rng, 0.03, 0.037), _u(rng, 0.07, 0.095)
    col = _pick(rng, CERAMIC)
    b.cylinder(0, 0, 0.0, h, r * 0.9, r, color=col, segments=18)
    b.box(r - 0.004, r + 0.018, -0.006, 0.006, h * 0.25, h * 0.8, col)
    return b.build()


def jar(rng: np.random.Generator, small: bool = False) -> ObjectModel:
    """A glass jar with a lid: "crème jar" (8-14 cm) or, small, "spice jar" (under 10 cm)."""
    b = Builder("spice jar" if small else "crème jar")
    r, h = (_u(rng, 0.018, 0.026), _u(rng, 0.06, 0.09)) if small else (_u(rng, 0.04, 0.06), _u(rng, 0.08, 0.14))
    glass = _pick(rng, ((0.78, 0.74, 0.62), (0.9, 0.88, 0.8), (0.6, 0.4, 0.25), (0.85, 0.6, 0.3)))
    lid = _pick(rng, (METAL, BLACK, (0.75, 0.2, 0.15), WHITE))
    b.cylinder(0, 0, 0.0, h - 0.015, r, color=glass, segments=18)
    b.cylinder(0, 0, h - 0.015, h, r * 1.04, color=lid, segments=18)
    return b.build()


def spice_jar(rng: np.random.Generator) -> ObjectModel:
    return jar(rng, small=True)


def cutting_board(rng: np.random.Generator) -> ObjectModel:
    """A wooden board, 1.5-2.5 cm thick; something may rest on it."""
    b = Builder("cutting board")
    w, d, t = _u(rng, 0.3, 0.45), _u(rng, 0.2, 0.3), _u(rng, 0.015, 0.025)
    b.box(-w / 2, w / 2, -d / 2, d / 2, 0.0, t, _pick(rng, WOODS[1:4]), Texture.WOOD)
    b.support(-w / 2 + 0.02, w / 2 - 0.02, -d / 2 + 0.02, d / 2 - 0.02, t, 0.4)
    return b.build()


def tray(rng: np.random.Generator) -> ObjectModel:
    """A serving tray: a thin plate with a low rim; cups and jars rest on the plate inside the rim."""
    b = Builder("tray")
    w, d, rim, t = _u(rng, 0.35, 0.5), _u(rng, 0.25, 0.35), _u(rng, 0.02, 0.035), 0.01
    col = _pick(rng, WOODS + (BLACK, METAL))
    e = 0.012
    b.box(-w / 2, w / 2, -d / 2, d / 2, 0.0, t, col, Texture.WOOD)
    for xa, xb, ya, yb in (
        (-w / 2, w / 2, -d / 2, -d / 2 + e),
        (-w / 2, w / 2, d / 2 - e, d / 2),
        (-w / 2, -w / 2 + e, -d / 2, d / 2),
        (w / 2 - e, w / 2, -d / 2, d / 2),
    ):
        b.box(xa, xb, ya, yb, t, rim, col, Texture.WOOD)
    b.support(-w / 2 + e + 0.005, w / 2 - e - 0.005, -d / 2 + e + 0.005, d / 2 - e - 0.005, t, 0.4)
    return b.build()


def bar_stool(rng: np.random.Generator) -> ObjectModel:
    """A stool at an island's overhang: a round seat on four legs with a foot rail."""
    b = Builder("bar stool")
    r, h = _u(rng, 0.16, 0.2), _u(rng, 0.63, 0.72)
    col = _pick(rng, (BLACK, METAL) + WOODS[:2])
    seat = _pick(rng, FABRICS + WOODS[:1])
    a = r * 0.75
    for sx in (-1, 1):
        for sy in (-1, 1):
            b.box(sx * a - 0.015, sx * a + 0.015, sy * a - 0.015, sy * a + 0.015, 0.0, h - 0.04, col)
    for sx in (-1, 1):
        b.box(sx * a - 0.01, sx * a + 0.01, -a, a, 0.25, 0.27, col)
    b.cylinder(0, 0, h - 0.04, h, r, color=seat, texture=Texture.FABRIC, segments=24)
    return b.build()


CATEGORIES: dict[str, Callable[[np.random.Generator], ObjectModel]] = {
    "bed": bed,
    "nightstand": nightstand,
    "wardrobe": wardrobe,
    "cabinet": cabinet,
    "desk": desk,
    "chair": chair,
    "dining table": dining_table,
    "sofa": sofa,
    "bookshelf": bookshelf,
    "floor lamp": floor_lamp,
    "table lamp": table_lamp,
    "monitor": monitor,
    "book stack": book_stack,
    "potted plant": potted_plant,
    "small plant": small_plant,
    "picture": picture,
    "TV": tv,
    "wall clock": wall_clock,
    "mirror": mirror,
    "wall shelf": wall_shelf,
    "kitchen island": kitchen_island,
    "kitchen counter": kitchen_counter,
    "cabinet/wardrobe part": upper_cabinet,
    "bowl": bowl,
    "coffee cup": coffee_cup,
    "crème jar": jar,
    "spice jar": spice_jar,
    "cutting board": cutting_board,
    "tray": tray,
    "bar stool": bar_stool,
}
"""Builder per category (``small plant`` is a small ``potted plant``, ``spice jar`` a small ``crème jar``: the
label each carries)."""

CONFUSABLE: dict[str, tuple[str, ...]] = {
    "bed": ("sofa",),
    "nightstand": ("cabinet",),
    "wardrobe": ("cabinet", "bookshelf"),
    "cabinet": ("nightstand", "wardrobe"),
    "desk": ("dining table",),
    "chair": ("sofa",),
    "dining table": ("desk",),
    "sofa": ("bed", "chair"),
    "bookshelf": ("wardrobe", "cabinet"),
    "floor lamp": ("table lamp",),
    "table lamp": ("floor lamp",),
    "monitor": ("TV",),
    "book stack": ("box",),
    "potted plant": ("vase",),
    "picture": ("mirror", "TV"),
    "TV": ("monitor", "picture"),
    "wall clock": ("picture",),
    "mirror": ("picture",),
    "wall shelf": ("shelf", "bookshelf"),
    "kitchen island": ("dining table", "kitchen counter"),
    "kitchen counter": ("cabinet", "kitchen island"),
    "cabinet/wardrobe part": ("cabinet", "wardrobe"),
    "bowl": ("coffee cup", "vase"),
    "coffee cup": ("bowl", "crème jar"),
    "crème jar": ("coffee cup", "vase"),
    "spice jar": ("crème jar", "bottle"),
    "cutting board": ("tray",),
    "tray": ("cutting board",),
    "bar stool": ("chair",),
}
"""Labels a panoptic model plausibly confuses each category with (the wrong-label dial)."""
