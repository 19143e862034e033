"""Object categories built from primitives with real-world proportions.

Every builder returns an ``ObjectModel`` in the object's canonical frame: metres, origin at the centre of
the bottom face of its bounding box, z up, the front faces +y and the back is at min y. Parts keep their
own colour and texture for rendering; the ground-truth mesh is the watertight union of the parts.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rescene_core.capture.synth.builder import (
    BLACK,
    BOOKS,
    FABRICS,
    METAL,
    PAINTED,
    WHITE,
    WOODS,
    Builder,
    ObjectModel,
    _legs,
    _pick,
    _u,
)
from rescene_core.capture.synth.kitchen_objects import (
    bar_stool,
    bowl,
    coffee_cup,
    cutting_board,
    jar,
    kitchen_counter,
    kitchen_island,
    spice_jar,
    tray,
    upper_cabinet,
)
from rescene_core.render import Texture


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
