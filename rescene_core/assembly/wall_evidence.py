"""Which side of a generated wall object faces its wall, read from the points the capture saw of it.

A generated asset's vertical faces do not always say which way it hangs: marching cubes over the
``lift`` grid bevels every edge of a box at 45 deg, and on a small shelf those bevels hold more of the
vertical area than the box's own sides, so the dominant face direction (``evidence.face_yaw``) can turn
the shelf 45 deg off its wall. A thin slab registered to flat, noisy points can also come out edge-on to
them (its thin side along the wall), which no turn within ``max_wall_yaw_deg`` repairs. Its observed
points settle both: mounted on a wall, the object's back lies on the wall plane, so each candidate side
(the dominant face direction, or no turn without one, and each horizontal asset axis turned onto the
wall's normal) is
put on the wall (turned about the box centre, pushed along the normal until the mesh touches the plane)
and scored by the share of the points its mesh box explains (``evidence.points_fit``).

* In the wall rule (``compile_wall``), within the yaw limit: an asset axis more than
  ``SIDE_MIN_SEPARATION_DEG`` from the dominant face direction is taken instead when it explains at least
  ``wall_side_min_gain`` more of the points.
* Before the rules run (``turn_to_wall_evidence``, ``attach``), beyond the yaw limit: a generated object
  with a ``mounts-on wall`` edge at least ``wall_confidence_min`` confident is turned onto a side beyond
  the limit when that side explains at least ``wall_evidence_turn_min_gain`` more of its points than the
  best side within the limit, on the wall its points lie on (the smallest median distance among the walls
  whose segment they face). Its registration turned it, so the turn corrects the registered pose, in full
  (not scaled by the edge's confidence), before the mesh is cut at the room's walls; the wall rule then
  squares it within the limit. The turn is logged per object (stage ``wall evidence``).

* Bad input: a generated object whose points' near side (``NEAR_SIDE_PERCENTILE``) lies more than
  ``wall_points_max_gap`` off its resolved wall contradicts its ``mounts-on wall`` edge; the wall rule
  does not apply (``points_off_wall``), so it keeps its registered pose and the skip says why.

Objects without points, with fewer than ``MIN_POINTS``, or exact shapes are left to the other rules.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import shapely
from numpy.typing import NDArray

from rescene_core.assembly.evidence import points_fit
from rescene_core.assembly.graph import build_forest
from rescene_core.assembly.objects import AssemblyObject
from rescene_core.assembly.room import Room, Wall
from rescene_core.assembly.transforms import (
    level_correction,
    nearest_axis,
    rotation_about,
    signed_yaw,
    translation,
)
from rescene_core.config import AttachmentConfig
from rescene_core.records import InstanceId, Relation, Root, SceneGraph

MIN_POINTS = 20
"""Fewest observed points that can say which side of an object faces its wall."""
SIDE_MIN_SEPARATION_DEG = 10.0
"""In the wall rule, an asset axis is another side than the dominant face direction when their yaws differ
by more than this (deg): the points choose between sides, the faces set the exact angle of the side they
show (a box fit to noisy points moves with a few degrees of yaw; a face histogram does not)."""


@dataclass(frozen=True)
class Side:
    """A candidate side of an object put on a wall: the yaw (rad, about the room's up) that turns it
    there, where it comes from ('keep', 'faces', 'asset axis k'), and the share of the object's points its
    mesh box explains once on the wall."""

    yaw: float
    source: str
    fit: float


def fold(yaw: float) -> float:
    """``yaw`` (rad) folded into [-pi/2, pi/2): a box's side and its opposite side face one wall alike."""
    return float((yaw + np.pi / 2) % np.pi - np.pi / 2)


def axis_yaws(world_from_asset: NDArray, up: NDArray, direction: NDArray) -> list[tuple[float, int]]:
    """(folded yaw in rad, asset axis index) turning each horizontal asset axis onto ``direction`` [3]
    (either sense) about ``up``."""
    up_idx, _, _ = nearest_axis(world_from_asset, up)
    axes = world_from_asset[:3, :3]
    return [(fold(signed_yaw(axes[:, k], direction, up)), k) for k in range(3) if k != up_idx]


def on_wall(obj: AssemblyObject, world_from_asset: NDArray, wall: Wall, up: NDArray, yaw: float) -> NDArray:
    """``world_from_asset`` [4, 4] turned by ``yaw`` (rad) about its mesh box centre and moved along the
    wall's normal until the mesh's nearest vertex lies on the wall plane."""
    verts = obj.world_vertices(world_from_asset)
    pivot = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
    turned = rotation_about(yaw * up, pivot) @ world_from_asset
    gap = float(wall.distance(obj.world_vertices(turned)).min())
    return translation(-gap * wall.normal) @ turned


def side_fits(
    obj: AssemblyObject, world_from_asset: NDArray, wall: Wall, up: NDArray, yaws: list[tuple[float, str]]
) -> list[Side]:
    """Each (yaw, source) of ``yaws`` scored on ``wall`` (see the module docstring); [] without points."""
    if obj.points is None or len(obj.points) < MIN_POINTS:
        return []
    return [Side(y, s, points_fit(obj, on_wall(obj, world_from_asset, wall, up, y)) or 0.0) for y, s in yaws]


def wall_side_yaw(
    obj: AssemblyObject,
    world_from_asset: NDArray,
    wall: Wall,
    up: NDArray,
    face: float | None,
    max_yaw: float,
    min_gain: float | None,
) -> tuple[float, dict]:
    """The yaw (rad) the wall rule turns generated ``obj`` (levelled, at ``world_from_asset``) by onto
    ``wall``, and what decided it. ``face``: the dominant face direction's yaw (None: none), the default;
    another side within ``max_yaw`` replaces it when its box explains at least ``min_gain`` more of the
    object's points (None: never)."""
    default = 0.0 if face is None else face
    if min_gain is None:
        return default, {}
    apart = np.radians(SIDE_MIN_SEPARATION_DEG)
    yaws = [(default, "faces" if face is not None else "keep")]
    yaws += [
        (y, f"asset axis {k}")
        for y, k in axis_yaws(world_from_asset, up, wall.normal)
        if abs(y) <= max_yaw and abs(fold(y - default)) > apart
    ]
    sides = side_fits(obj, world_from_asset, wall, up, yaws)
    if len(sides) < 2:
        return default, {}
    best = max(sides[1:], key=lambda s: s.fit)
    if best.fit < sides[0].fit + min_gain:
        return default, {}
    return best.yaw, {
        "side_from_points": best.source,
        "side_fit": best.fit,
        "faces_fit": sides[0].fit,
        "faces_yaw_deg": float(np.degrees(default)),
    }


NEAR_SIDE_PERCENTILE = 5.0
"""Percentile of the points' distances to a wall taken as their near side (robust to a few stray points)."""


def points_off_wall(obj: AssemblyObject, wall: Wall, max_gap: float | None) -> str | None:
    """Why generated ``obj``'s observed points contradict mounting it on ``wall`` (None: they do not, or
    there are too few of them, or it is an exact shape): their near side lies more than ``max_gap`` m
    in front of the plane or behind it."""
    pts = obj.points
    if max_gap is None or obj.exact_shape or pts is None or len(pts) < MIN_POINTS:
        return None
    near = float(np.percentile(wall.distance(pts), NEAR_SIDE_PERCENTILE))
    if abs(near) <= max_gap:
        return None
    return (
        f"the object's observed points come no nearer than {near:.2f} m to wall {wall.id} (more than "
        f"{max_gap} m): they contradict the mounts-on wall edge, so it keeps its registered pose"
    )


LYING_MAX_RATIO = 0.25
"""Points whose height spread is at most this share of their spread across the wall lie flat: a slab lying
down shows the wall its thin edge, and nothing hangs that way (a picture, a TV, a cabinet's doors show it
their broad face)."""
LYING_SPREAD = (5.0, 95.0)
"""Percentiles of the points' heights and distances to the wall whose difference is their spread."""
RESTING_BAND = (0.03, 0.01)
"""Another object's points from this far (m) below to this far above an object's lowest points (2nd
percentile) under its footprint are a surface it lies on."""
RESTING_MIN_POINTS = 20
"""Fewest such points (under the footprint of the object's points, grown by RESTING_AROUND)."""
RESTING_AROUND = 0.02


def lies_on_a_support(
    objects: dict[InstanceId, AssemblyObject], child: InstanceId, wall: Wall, room: Room
) -> str | None:
    """Why generated ``child``'s observed points contradict mounting it on ``wall`` because it lies flat on
    another object (None: they do not, or too few points, or an exact shape): its points' height spread is
    at most LYING_MAX_RATIO of their spread across the wall, and another object's points make a surface
    right under them (RESTING_BAND, RESTING_MIN_POINTS). A cutting board lying on a counter 3 cm from the
    backsplash (egocentric development seed 3, answered ``mounts-on wall`` at 0.73) was moved 2.8 cm onto
    the wall, its centre error 0.005 -> 0.028 m: what carries it is the counter's top, where it was seen."""
    obj = objects[child]
    pts = obj.points
    if obj.exact_shape or pts is None or len(pts) < MIN_POINTS:
        return None
    pts = np.asarray(pts, np.float64)
    heights = room.floor_distance(pts)
    tall = float(np.subtract(*np.percentile(heights, LYING_SPREAD[::-1])))
    deep = float(np.subtract(*np.percentile(wall.distance(pts), LYING_SPREAD[::-1])))
    if tall > LYING_MAX_RATIO * deep:
        return None
    bottom = float(np.percentile(heights, 2.0))
    region = shapely.MultiPoint(pts[:, :2]).convex_hull.buffer(RESTING_AROUND)
    for other, oobj in objects.items():
        if other == child or oobj.points is None or len(oobj.points) < RESTING_MIN_POINTS:
            continue
        opts = np.asarray(oobj.points, np.float64)
        oh = room.floor_distance(opts)
        band = (oh >= bottom - RESTING_BAND[0]) & (oh <= bottom + RESTING_BAND[1])
        if int(band.sum()) < RESTING_MIN_POINTS:
            continue
        under = int(np.count_nonzero(shapely.contains_xy(region, opts[band, 0], opts[band, 1])))
        if under >= RESTING_MIN_POINTS:
            return (
                f"the object's observed points lie flat ({tall:.3f} m tall, {deep:.3f} m deep off wall {wall.id}) on "
                f"object {int(other)}'s surface at {bottom:.3f} m: they contradict the mounts-on wall edge, so it "
                "keeps its registered pose"
            )
    return None


def lies_on(obj: AssemblyObject, room: Room) -> Wall | None:
    """The wall whose plane the object's points lie nearest in bulk (median distance), among the walls
    whose segment their median faces; None without points or walls."""
    pts = obj.points
    if pts is None or len(pts) < MIN_POINTS or not room.walls:
        return None
    best: tuple[float, Wall] | None = None
    for wall in room.walls:
        along = float(np.median(wall.along(pts)))
        if not 0.0 <= along <= wall.length:
            continue
        dist = abs(float(np.median(wall.distance(pts))))
        if best is None or dist < best[0]:
            best = (dist, wall)
    return None if best is None else best[1]


def turn_to_wall_evidence(
    objects: dict[InstanceId, AssemblyObject], graph: SceneGraph, room: Room, config: AttachmentConfig
) -> tuple[dict[InstanceId, AssemblyObject], list[tuple[InstanceId, dict]]]:
    """``objects`` with each generated wall object whose points show it turned beyond the yaw limit
    re-registered onto the side they show (see the module docstring), and per turned object what was
    done (for the operation log: wall, yaw, fits, the world-frame turn)."""
    min_gain = config.wall_evidence_turn_min_gain
    if min_gain is None or not room.walls:
        return objects, []
    max_yaw = np.radians(config.max_wall_yaw_deg)
    out = dict(objects)
    done: list[tuple[InstanceId, dict]] = []
    for child, edge in build_forest(graph, set(objects)).edges.items():
        obj = objects[child]
        if edge.relation is not Relation.MOUNTS_ON or edge.parent is not Root.WALL or obj.exact_shape:
            continue
        if edge.confidence < config.wall_confidence_min:
            continue
        wall = lies_on(obj, room)
        if wall is None:
            continue
        pose = obj.world_from_asset
        verts = obj.world_vertices()
        pivot = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
        level, _ = level_correction(pose, room.up, pivot, np.radians(config.max_level_tilt_deg))
        levelled = level @ pose
        yaws = [(0.0, "keep")] + [(y, f"asset axis {k}") for y, k in axis_yaws(levelled, room.up, wall.normal)]
        sides = side_fits(obj, levelled, wall, room.up, yaws)
        inside = max((s for s in sides if abs(s.yaw) <= max_yaw), key=lambda s: s.fit, default=None)
        beyond = max((s for s in sides if abs(s.yaw) > max_yaw), key=lambda s: s.fit, default=None)
        if inside is None or beyond is None or beyond.fit < inside.fit + min_gain:
            continue
        turn = rotation_about(beyond.yaw * room.up, pivot)
        out[child] = replace(obj, world_from_asset=turn @ pose)
        done.append(
            (
                child,
                {
                    "wall_id": wall.id,
                    "yaw_deg": float(np.degrees(beyond.yaw)),
                    "side": beyond.source,
                    "fit_turned": beyond.fit,
                    "fit_within_limit": inside.fit,
                    "transform": turn,
                    "reason": (
                        f"put on wall {wall.id}, its mesh box turned {np.degrees(beyond.yaw):.0f} deg explains "
                        f"{beyond.fit:.0%} of its observed points, within the {config.max_wall_yaw_deg:.0f} deg "
                        f"yaw limit at most {inside.fit:.0%}: its registration turned it"
                    ),
                },
            )
        )
    return out, done
