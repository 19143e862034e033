"""The room shell as solid geometry: the floor's height, each wall's trimmed extent and the boxes behind
the walls' planes. The exports (GLB, MJCF, USD), the collider edits and the physics check build on it."""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Polygon

from rescene_core.records import RoomShell, WallPlane


def floor_height(shell: RoomShell) -> float:
    """Height of the floor plane at the origin (m), from ``normal . x + offset = 0``."""
    nz = shell.floor.normal[2]
    return float(-shell.floor.offset / nz) if abs(nz) > 1e-9 else 0.0


WALL_TRIM_STEP = 0.005
"""Resolution (m) along a wall at which its box's ends are trimmed back to the room's outline."""
WALL_TRIM_PROBE = 0.005
"""How far (m) behind the wall's plane the trim looks for the room's floor polygon."""


def wall_extent(shell: RoomShell, wall: WallPlane) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The part (start, end) [2] of a wall's segment whose box stays out of the room (None: no length).

    Estimated segments overshoot their corners by a few centimetres. At a corner the room turns around (an
    L-shaped room's inner corner, a wardrobe's niche), an overshooting wall's box reaches into the other
    part of the room, where furniture standing against the other wall meets it at t = 0 and is thrown off.
    Each end is trimmed back until the wall's back side (``WALL_TRIM_PROBE`` behind its plane) leaves the
    floor polygon; a wall whose back side lies inside the polygon all along keeps its whole segment."""

    start, end = np.asarray(wall.segment, np.float64)
    length = float(np.linalg.norm(end - start))
    if not np.isfinite(length) or length <= 0:
        return None
    poly = Polygon(shell.floor_polygon) if len(shell.floor_polygon) >= 3 else None
    if poly is None or not poly.is_valid or poly.area <= 0:
        return start, end
    tangent = (end - start) / length
    normal = np.asarray(wall.plane.normal, np.float64)[:2]
    normal = normal / max(float(np.linalg.norm(normal)), 1e-12)
    t = np.linspace(0.0, length, max(2, int(np.ceil(length / WALL_TRIM_STEP)) + 1))
    probe = start + t[:, None] * tangent - WALL_TRIM_PROBE * normal
    outside = ~shapely.contains_xy(poly, probe[:, 0], probe[:, 1])
    if not outside.any():
        return start, end
    first, last = int(np.argmax(outside)), len(t) - 1 - int(np.argmax(outside[::-1]))
    if t[last] - t[first] <= 0:
        return None
    return start + t[first] * tangent, start + t[last] * tangent


def wall_boxes(
    shell: RoomShell, thickness: float, height: float
) -> list[tuple[int, NDArray[np.float64], float, float]]:
    """One box per wall, behind its plane over its trimmed extent (``wall_extent``): (wall id, world centre
    [3], yaw about +z (rad), length (m)); the box is ``length`` x ``thickness`` x ``height`` before the yaw."""
    z0 = floor_height(shell)
    out = []
    for wall in shell.walls:
        extent = wall_extent(shell, wall)
        if extent is None:
            continue
        (x0, y0), (x1, y1) = extent
        normal = np.asarray(wall.plane.normal, dtype=np.float64)
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, z0 + height / 2]) - normal * thickness / 2
        out.append((wall.id, centre, float(np.arctan2(y1 - y0, x1 - x0)), float(np.hypot(x1 - x0, y1 - y0))))
    return out
