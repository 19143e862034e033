"""Colour tests: a wall's paint, its shadow (the wall's hue darkened) and what is left of a colour
after the best multiple of a reference colour is taken off."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.config import SegmentConfig


def _hue_rest(colours: NDArray, reference: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each colour [n, 3] (RGB in [0, 1]), the multiple k [n] of ``reference`` [3] nearest to it and what
    is left of it after that multiple is taken off [n] (RGB distance / sqrt 3): 0 for the reference lit or
    shaded, more as the hue departs from it."""
    k = colours @ reference / max(float(reference @ reference), 1e-9)
    return k, np.linalg.norm(colours - k[:, None] * reference, axis=1) / np.sqrt(3.0)


def _shaded(colours: NDArray, wall_colour: NDArray, tint: float) -> NDArray[np.bool_]:
    """Whether each colour [s, 3] (RGB in [0, 1]) is the wall's colour [3] darkened: a multiple k < 1 of it
    leaves less than ``tint`` (RGB distance / sqrt 3) of the colour unexplained (a shadow keeps the hue)."""
    k, rest = _hue_rest(colours, wall_colour)
    return (k < 1.0) & (rest < tint)


def _of_paint(colours: NDArray, wall_colour: NDArray, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Whether each colour [s, 3] (RGB in [0, 1]) is its wall's paint [3]: within ``flush_colour_step`` of it
    (RGB distance / sqrt 3) or the paint darkened (``_shaded``). The wall in a shadow (under a wall shelf,
    behind furniture) differs in colour but is no picture: taken as one, it joins the shelf casting it and
    buries the shelf in wall."""
    step = np.linalg.norm(colours - wall_colour, axis=1) / np.sqrt(3.0)
    return (step < cfg.flush_colour_step) | _shaded(colours, wall_colour, cfg.flush_shadow_tint)


def _in_shadow(colours: NDArray, wall_colour: NDArray | None, cfg: SegmentConfig) -> bool:
    """Whether a region's colours [k, 3] (RGB in [0, 1]) are, on average, its wall's colour [3] darkened
    (``_shaded``): a sharp outline of such a region is the edge of a shadow, not of a picture."""
    if wall_colour is None:
        return False
    return bool(_shaded(colours.mean(axis=0)[None], wall_colour, cfg.flush_shadow_tint)[0])
