"""The kitchen's object categories (the egocentric preset): island, counters, wall cabinets and the
clutter on them, built like ``objects`` (canonical frame: metres, origin at the bottom centre, z up)."""

from __future__ import annotations

import numpy as np

from rescene_core.capture.synth.builder import (
    BLACK,
    FABRICS,
    METAL,
    PAINTED,
    WHITE,
    WOODS,
    Builder,
    ObjectModel,
    _pick,
    _u,
)
from rescene_core.render import Texture

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
