"""``mounts-on`` wall: resolve the canonical wall root to a wall plane, then make the back surface coplanar.

Wall resolution (per child): for every wall, the child's back axis is the horizontal asset axis nearest
to the wall's outward normal; the energy is the coplanarity residual (distance of the back surface from
the plane, m) + ``wall_normal_weight`` x the normal mismatch (rad) + the distance by which the child lies
beyond the wall segment (m). Walls needing more than ``max_wall_yaw_deg`` of yaw are not candidates.
An edge that already names its wall (``Edge.wall_id``) gets a bonus of half the yaw-limit penalty
(``wall_normal_weight`` x ``max_wall_yaw_deg`` / 2) on that wall, and may keep it beyond the yaw limit,
but a wall the geometry clearly prefers wins (fused graphs name the wrong wall of a corner now and then).

Lateral order (per wall): the along-wall target of each child is its current along-wall position,
clamped so the object stays ``wall_corner_margin`` m inside the segment ends; objects side by side keep
their original order ``contact_gap`` apart (``keep_lateral_order``; objects hanging one above the other
are left to depenetration).

Back side of a generated asset: its dominant vertical face direction, or, when another side (a horizontal
asset axis more than 10 deg from it) put on the wall explains clearly more of its observed points, that
side (``rescene_core.assembly.wall_evidence``); points far off the wall, or lying flat on another object
(``lies_on_a_support``), refuse the rule.

Closed-form minimiser: level (as for the floor), yaw the back axis onto the outward normal, translate
along the normal until the back surface lies on the plane, translate along the wall to the lateral target,
and keep the object above the floor (and below the ceiling when known).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.evidence import (
    centre_inside_wall,
    face_yaw,
    level_pivot,
    levelling,
    wall_gap,
    yaw_to_direction,
)
from rescene_core.assembly.room import Wall
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import (
    nearest_axis,
    rotation_about,
    signed_yaw,
    translation,
)
from rescene_core.assembly.wall_evidence import lies_on_a_support, points_off_wall, wall_side_yaw
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId, Relation, Root


@dataclass(frozen=True)
class WallChoice:
    """Where one wall-mounted child goes: wall, back axis (asset index, sign), along-wall target (m)."""

    wall: Wall
    axis: int
    sign: float
    target_along: float
    cost: float


def horizontal_axes(pose: NDArray, up: NDArray) -> tuple[int, ...]:
    up_idx, _, _ = nearest_axis(pose, up)
    return tuple(k for k in range(3) if k != up_idx)


def wall_cost(state: LayoutState, child: InstanceId, wall: Wall) -> tuple[float, int, float, float]:
    """(energy, back-axis index, sign, yaw needed in rad) of mounting ``child`` on ``wall``.

    Exact shapes: the back axis is the horizontal asset axis nearest the wall's outward direction.
    Generated assets (``rescene_core.assembly.evidence``): the yaw comes from the mesh's vertical faces
    (index -1); a mesh with no face direction within ``max_wall_yaw_deg`` needs no yaw (0) but pays
    ``wall_normal_weight`` x the yaw limit, so a wall its faces agree with is preferred."""
    pose = state.pose(child)
    max_yaw = np.radians(state.config.max_wall_yaw_deg)
    found = yaw_to_direction(state, child, -wall.normal, horizontal_axes(pose, state.room.up), max_yaw)
    if found is None:
        idx, sign, yaw, penalty = -1, 1.0, 0.0, max_yaw
    else:
        (yaw, idx, sign), penalty = found, abs(found[0])
    coplanar = abs(wall_gap(state, child, wall))
    along = wall.along(state.centre(child)[None])[0]
    beyond = max(0.0, -along, along - wall.length)
    return coplanar + state.config.wall_normal_weight * penalty + beyond, idx, sign, yaw


def resolve_walls(state: LayoutState) -> dict[InstanceId, WallChoice]:
    """Wall resolution for every ``mounts-on wall`` edge, with lateral targets that keep the wall's order."""
    cfg, room = state.config, state.room
    chosen: dict[InstanceId, tuple[Wall, int, float, float]] = {}
    for child, edge in state.forest.edges.items():
        if edge.relation is not Relation.MOUNTS_ON or edge.parent is not Root.WALL:
            continue
        if not room.walls:
            continue
        named = room.wall(edge.wall_id) if edge.wall_id is not None else None
        best = None
        for wall in room.walls:
            cost, idx, sign, yaw = wall_cost(state, child, wall)
            if abs(yaw) > np.radians(cfg.max_wall_yaw_deg) and wall is not named:
                continue
            if wall is named:  # the graph's wall wins ties; a wall the geometry clearly prefers still wins
                cost -= cfg.wall_normal_weight * np.radians(cfg.max_wall_yaw_deg) * 0.5
            if best is None or cost < best[3]:
                best = (wall, idx, sign, cost)
        if best is None:
            state.skip(child, "wall resolution", f"no wall within the {cfg.max_wall_yaw_deg} deg yaw limit")
            continue
        chosen[child] = best
        state.log(child, "wall resolution", "resolve wall root", wall_id=best[0].id, energy=best[3])
    plans: dict[InstanceId, WallChoice] = {}
    for wall in room.walls:
        kids = [c for c, v in chosen.items() if v[0] is wall]
        if not kids:
            continue
        along = np.array([wall.along(state.centre(c)[None])[0] for c in kids])
        half = np.array([0.5 * np.ptp(wall.along(state.vertices(c))) for c in kids])
        lo = cfg.wall_corner_margin + half
        hi = wall.length - cfg.wall_corner_margin - half
        target = np.where(lo <= hi, np.clip(along, lo, np.maximum(lo, hi)), 0.5 * wall.length)
        z = [state.room.floor_distance(state.vertices(c)) for c in kids]
        target = keep_lateral_order(along, target, half, lo, hi, [(v.min(), v.max()) for v in z], cfg.contact_gap)
        for c, t in zip(kids, target):
            w, idx, sign, cost = chosen[c]
            plans[c] = WallChoice(w, idx, sign, float(t), cost)
    return plans


def keep_lateral_order(along, target, half, lo, hi, heights, gap) -> NDArray[np.float64]:
    """Along-wall targets (m) in the original order ``along``, with objects side by side kept ``gap`` m
    apart: a forward pass pushes right, a backward pass pulls back under the upper bounds ``hi``; the lower
    bounds ``lo`` win when the wall is too short for all of them.

    Two objects are side by side when their height ranges overlap, unless they overlap along the wall by
    more than they overlap in height: those hang one above the other (a picture over a shelf, 2 cm into
    it), and sliding one sideways by its whole width to part them would move it far from where it was
    seen; depenetration parts them in the wall's plane instead."""
    order = np.argsort(along, kind="stable")
    t = np.array(target, dtype=np.float64)

    def overlap(a: int, b: int) -> bool:
        vertical = min(heights[a][1], heights[b][1]) - max(heights[a][0], heights[b][0])
        lateral = half[a] + half[b] - abs(along[a] - along[b])
        return vertical > 0.0 and (lateral <= 0.0 or vertical > lateral)

    for k, i in enumerate(order):
        for j in order[:k]:
            if overlap(i, j):
                t[i] = max(t[i], t[j] + half[i] + half[j] + gap)
    for k in range(len(order) - 1, -1, -1):
        i = order[k]
        t[i] = min(t[i], max(hi[i], lo[i]))
        for j in order[k + 1 :]:
            if overlap(i, j):
                t[i] = min(t[i], t[j] - half[i] - half[j] - gap)
        t[i] = max(t[i], lo[i])
    return t


def compile_wall(
    state: LayoutState, child: InstanceId, edge: Edge, plan: WallChoice | None
) -> tuple[NDArray[np.float64] | None, dict[str, Any]]:
    """World-frame Sim(3) [4, 4] mounting ``child`` flat on its resolved wall (None: no wall resolved)."""
    if plan is None:
        return None, {"reason": "no wall resolved for this edge"}
    cfg, room, wall = state.config, state.room, plan.wall
    obj = state.objects[child]
    contradiction = points_off_wall(obj, wall, cfg.wall_points_max_gap) or lies_on_a_support(
        state.objects, child, wall, room
    )
    if contradiction is not None:
        return None, {"reason": contradiction}
    pose = state.pose(child)
    side: dict[str, Any] = {}
    pivot = level_pivot(state, child)
    # nothing hangs on a wall on its side: a generated asset past the exact shapes' limit is registration rolling
    # a box-like shape about its long axis (a wall shelf 48 deg)
    correction, tilt = levelling(state, child, pose, pivot)
    if plan.axis >= 0:  # exact shape: the asset axis is the object's back axis
        axis = plan.sign * (correction @ pose)[:3, plan.axis]
        yaw = signed_yaw(axis, -wall.normal, room.up)
    else:  # generated asset: the back face is read from the mesh faces (none found: keep the yaw)
        faces = face_yaw(state, child, -wall.normal, np.radians(cfg.max_wall_yaw_deg), correction @ pose)
        yaw, side = wall_side_yaw(
            obj, correction @ pose, wall, room.up, faces, np.radians(cfg.max_wall_yaw_deg), cfg.wall_side_min_gain
        )
    yaw = float(np.clip(yaw, -np.radians(cfg.max_wall_yaw_deg), np.radians(cfg.max_wall_yaw_deg)))
    correction = rotation_about(yaw * room.up, pivot) @ correction
    moved = apply(correction @ pose, obj.vertices)
    gap = float(wall.distance(moved).min())
    centre_in_front = centre_inside_wall(wall, 0.5 * (moved.min(axis=0) + moved.max(axis=0)))
    excess = cfg.completion_min_excess
    if gap < 0.0 and not obj.exact_shape and centre_in_front and excess is not None and -gap > excess:
        gap = 0.0  # deep penetration of a generated asset whose centre is in front: completion, in contact
    push = -gap
    centre = 0.5 * (moved.min(axis=0) + moved.max(axis=0))
    slide = plan.target_along - float(wall.along(centre[None])[0])
    floor_gap = float(room.floor_distance(moved).min())
    lift = max(0.0, -floor_gap)
    ceiling = room.shell.ceiling_height
    if ceiling is not None:
        top = float(room.floor_distance(moved).max())
        if top + lift > ceiling:
            lift = max(ceiling - top, -floor_gap)
    correction = translation(push * wall.normal + slide * wall.tangent + lift * room.up) @ correction
    info = {
        "wall_id": wall.id,
        "tilt_removed_deg": float(np.degrees(tilt)),
        "yaw_deg": float(np.degrees(yaw)),
        "normal_m": push,
        "along_m": slide,
        "vertical_m": lift,
        **side,
    }
    return correction, info
