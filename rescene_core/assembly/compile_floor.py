"""``rests-on`` floor: snap the lower contact surface onto the floor plane and keep the footprint inside.

Energy: signed distance of the child's lowest points to the floor plane, plus the footprint area outside
the floor polygon. Closed-form minimiser: (1) level the asset axis nearest to the floor normal (removes a
tilt of at most ``max_level_tilt_deg``), (2) optionally turn about the vertical onto the nearest room axis
when that is within ``max_floor_yaw_deg``, (3) translate along the floor normal so the lowest vertex lies
on the floor (at most ``max_floor_snap`` m), (4) translate the footprint by the smallest step that puts it
inside the floor polygon shrunk by ``wall_contact_gap``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.evidence import (
    centre_inside_polygon,
    level_pivot,
    levelled_refit,
    levelling,
    polygon_excursion,
)
from rescene_core.assembly.objects import footprint
from rescene_core.assembly.room import Room, fit_translation
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import (
    nearest_axis,
    rotation_about,
    signed_yaw,
    translation,
)
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId


def inner_polygon(room: Room, margin: float):
    """Floor polygon shrunk by ``margin`` m (mitred corners), or None without a polygon."""
    if room.polygon is None:
        return None
    inner = room.polygon.buffer(-margin, join_style="mitre")
    return inner if not inner.is_empty else room.polygon


def yaw_to_room_axes(state: LayoutState, pose: NDArray, pivot: NDArray, max_yaw_rad: float):
    """Rotation about the vertical through ``pivot`` aligning the asset's horizontal axes with the nearest
    wall direction, or identity when no wall direction is within ``max_yaw_rad``."""
    room = state.room
    if not room.walls:
        return np.eye(4), 0.0
    _, _, ax = nearest_axis(pose, room.walls[0].tangent, candidates=(0, 1))
    best = None
    for wall in room.walls:
        for direction in (wall.tangent, wall.normal):
            yaw = signed_yaw(ax, direction, room.up)
            yaw = (yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4  # symmetry of a rectangle's axes
            if best is None or abs(yaw) < abs(best):
                best = yaw
    if best is None or abs(best) < 1e-9 or abs(best) > max_yaw_rad:
        return np.eye(4), 0.0
    return rotation_about(best * room.up, pivot), float(best)


def compile_floor(state: LayoutState, child: InstanceId, edge: Edge) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """World-frame Sim(3) [4, 4] that puts ``child`` on the floor, and what it did."""
    cfg, room = state.config, state.room
    obj = state.objects[child]
    pose = state.pose(child)
    pivot = level_pivot(state, child)
    info: dict[str, Any] = {}
    level, tilt = levelling(state, child, pose, pivot)
    correction = level
    info["tilt_removed_deg"] = float(np.degrees(tilt))
    if cfg.floor_yaw_align:
        yaw_m, yaw = yaw_to_room_axes(state, level @ pose, pivot, np.radians(cfg.max_floor_yaw_deg))
        correction = yaw_m @ correction
        info["yaw_deg"] = float(np.degrees(yaw))
    moved = apply(correction @ pose, obj.vertices)
    drop = -float(room.floor_distance(moved).min())
    if abs(drop) > cfg.max_floor_snap:
        info["snap_clamped_from"] = drop
        drop = float(np.clip(drop, -cfg.max_floor_snap, cfg.max_floor_snap))
    correction = translation(drop * room.up) @ correction
    info["vertical_m"] = drop
    # a mesh levelled by a large tilt is not the one registered on the points: its surface goes back onto them
    refit = levelled_refit(state, child, correction @ pose)
    if refit is not None:
        correction = translation(refit) @ correction
        info["refit_m"] = refit
    inner = inner_polygon(room, cfg.wall_contact_gap)
    if inner is not None:
        moved = apply(correction @ pose, obj.vertices)
        fp = footprint(moved)
        if not obj.exact_shape and not fp.within(room.polygon):
            # generated asset reaching deep beyond the polygon with its centre inside: only the part inside
            # the room counts (a completion error, evidence.py); a shallow crossing is repaired in full
            centre = 0.5 * (moved.min(axis=0) + moved.max(axis=0))
            excess = cfg.completion_min_excess
            deep = excess is not None and polygon_excursion(room.polygon, fp) > excess
            if deep and centre_inside_polygon(room.polygon, centre):
                core = fp.intersection(inner)
                fp = core.convex_hull if not core.is_empty and core.area > 0 else fp
        if not fp.within(room.polygon):
            shift = fit_translation(fp, inner)
            if shift is None:
                info["footprint"] = "does not fit inside the floor polygon; left in place"
            else:
                correction = translation([shift[0], shift[1], 0.0]) @ correction
                info["footprint_shift_m"] = shift
    return correction, info
