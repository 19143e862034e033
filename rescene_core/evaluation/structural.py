"""Structural metrics of a layout (paper Appendix 'Structural Metrics'), shared by the attachment
benchmark and the evaluation of runs.

Definitions (tolerances in ``StructuralTolerances``):
- out of bound: an object whose convex footprint is not inside the floor polygon grown by ``oob``.
- collision: a pair of objects, neither an ancestor of the other in the graph, whose meshes intersect
  (fcl triangle test) or one of which lies inside the other (closed meshes); the rate divides by the
  number of such non-related pairs.
- floor contact: a ``rests-on floor`` child whose lowest point is within ``floor`` m of the floor plane.
- wall contact: a ``mounts-on wall`` child with a wall (the edge's ``wall_id`` when set, else any) whose
  plane is within ``wall`` m of the child's back surface, with no part more than ``wall`` m behind it,
  whose back axis is within ``wall_angle_deg`` of the wall's outward normal, and that it overlaps.
- support contact: a ``rests-on object`` child whose lowest point is within ``support`` m of an
  upward-facing support level of its parent, with its footprint centroid over that level.
- attachment contact: a ``mounts-on`` child meeting the wall condition (wall parent) or lying within
  ``support`` m of its parent's mesh (object parent).
A pass rate is None when no edge of that kind exists.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import fcl
import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.compile_support import support_levels_of
from rescene_core.assembly.compile_wall import horizontal_axes
from rescene_core.assembly.graph import build_forest
from rescene_core.assembly.objects import AssemblyObject, footprint
from rescene_core.assembly.room import Room, room_from_shell
from rescene_core.assembly.transforms import nearest_axis, rigid_change, signed_yaw
from rescene_core.records import InstanceId, Layout, Relation, RoomShell, Root, SceneGraph


@dataclass(frozen=True)
class StructuralTolerances:
    """Pass tolerances of the structural metrics (metres unless named otherwise)."""

    floor: float = 0.02
    """Floor contact: |lowest point - floor| at most this (2 x the 0.01 m contact gap)."""
    wall: float = 0.03
    """Wall contact: back surface within this of the wall plane."""
    wall_angle_deg: float = 5.0
    """Wall contact: back axis within this angle of the wall's outward normal (deg)."""
    support: float = 0.02
    """Support / object-attachment contact distance."""
    oob: float = 0.01
    """A footprint this far beyond the floor polygon is still inside."""
    support_normal_deg: float = 10.0
    """Support faces: normal within this of the floor normal (deg)."""
    support_level: float = 0.01
    """Support faces within this height form one level."""


def _wall_ok(room: Room, verts: NDArray, pose: NDArray, wall_id: int | None, tol: StructuralTolerances) -> bool:
    walls = [w for w in room.walls if wall_id is None or w.id == wall_id]
    for wall in walls:
        dist = wall.distance(verts)
        along = wall.along(verts)
        if along.max() <= 0 or along.min() >= wall.length:
            continue
        if abs(dist.min()) > tol.wall:
            continue
        _, _, axis = nearest_axis(pose, -wall.normal, horizontal_axes(pose, room.up))
        if abs(np.degrees(signed_yaw(axis, -wall.normal, room.up))) <= tol.wall_angle_deg:
            return True
    return False


def _rate(flags: list[bool]) -> float | None:
    return float(np.mean(flags)) if flags else None


def structural_metrics(
    objects: Mapping[int, AssemblyObject],
    poses: Layout | Mapping[int, NDArray] | None,
    graph: SceneGraph,
    shell: RoomShell,
    registered: Mapping[int, NDArray] | None = None,
    tolerances: StructuralTolerances | None = None,
) -> dict[str, Any]:
    """Structural metrics of ``objects`` at ``poses`` (a Layout, id -> world_from_asset [4, 4], or None
    for the objects' own poses). ``registered``: reference poses for the per-object pose change (default:
    the objects' own world_from_asset). Returns plain JSON types."""
    tol = tolerances or StructuralTolerances()
    room = room_from_shell(shell)
    if isinstance(poses, Layout):
        pose_of = dict(poses.world_from_asset)
    else:
        pose_of = dict(poses or {})
    objs = {InstanceId(int(k)): o for k, o in objects.items()}
    pose = {i: np.asarray(pose_of.get(i, pose_of.get(int(i), o.world_from_asset)), np.float64) for i, o in objs.items()}
    verts = {i: o.world_vertices(pose[i]) for i, o in objs.items()}
    forest = build_forest(graph, set(objs))
    n = len(objs)

    oob = []
    if room.polygon is not None:
        grown = room.polygon.buffer(tol.oob)
        oob = sorted(int(i) for i in objs if not footprint(verts[i]).within(grown))

    world = CollisionWorld(objs)
    pairs = world.colliding_pairs(pose, skip=forest.related)
    related_pairs = sum(len(forest.subtree(i)) - 1 for i in objs)
    non_related = n * (n - 1) // 2 - related_pairs

    floor_ok, wall_ok, support_ok, attach_ok = {}, {}, {}, {}
    for child, edge in forest.edges.items():
        v = verts[child]
        if edge.parent is Root.FLOOR and edge.relation is Relation.RESTS_ON:
            floor_ok[child] = bool(abs(room.floor_distance(v).min()) <= tol.floor)
        elif edge.parent is Root.WALL and edge.relation is Relation.MOUNTS_ON:
            ok = _wall_ok(room, v, pose[child], edge.wall_id, tol)
            wall_ok[child] = ok
            attach_ok[child] = ok
        elif not isinstance(edge.parent, Root):
            parent = InstanceId(edge.parent)
            if edge.relation is Relation.RESTS_ON:
                bottom = float(room.floor_distance(v).min())
                centroid = footprint(v).centroid
                levels = support_levels_of(
                    verts[parent], objs[parent].faces, room, tol.support_normal_deg, tol.support_level
                )
                support_ok[child] = any(
                    abs(lv.height - bottom) <= tol.support and lv.polygon.buffer(tol.support).contains(centroid)
                    for lv in levels
                )
            else:
                result = fcl.DistanceResult()
                dist = fcl.distance(
                    world.fcl_object(child, pose[child]),
                    world.fcl_object(parent, pose[parent]),
                    fcl.DistanceRequest(),
                    result,
                )
                attach_ok[child] = bool(dist <= tol.support)

    reference = registered if registered is not None else {i: o.world_from_asset for i, o in objs.items()}
    change = {}
    for i, o in objs.items():
        ref = np.asarray(reference.get(i, reference.get(int(i), o.world_from_asset)), np.float64)
        ref_v = o.world_vertices(ref)
        centre_shift = float(
            np.linalg.norm(0.5 * (verts[i].min(0) + verts[i].max(0)) - 0.5 * (ref_v.min(0) + ref_v.max(0)))
        )
        _, rot = rigid_change(ref, pose[i])
        change[str(int(i))] = {"centre_m": centre_shift, "rotation_deg": rot}
    shifts = [c["centre_m"] for c in change.values()]
    return {
        "object_count": n,
        "oob_count": len(oob),
        "oob_rate": len(oob) / n if n else 0.0,
        "oob_objects": oob,
        "collision_pairs": len(pairs),
        "non_related_pairs": non_related,
        "collision_rate": len(pairs) / non_related if non_related else 0.0,
        "colliding": [[int(a), int(b)] for a, b in pairs],
        "floor_contact_pass": _rate(list(floor_ok.values())),
        "wall_contact_pass": _rate(list(wall_ok.values())),
        "support_contact_pass": _rate(list(support_ok.values())),
        "attachment_contact_pass": _rate(list(attach_ok.values())),
        "contact_failures": {
            "floor": sorted(int(i) for i, ok in floor_ok.items() if not ok),
            "wall": sorted(int(i) for i, ok in wall_ok.items() if not ok),
            "support": sorted(int(i) for i, ok in support_ok.items() if not ok),
            "attachment": sorted(int(i) for i, ok in attach_ok.items() if not ok),
        },
        "pose_change": change,
        "pose_change_median_m": float(np.median(shifts)) if shifts else 0.0,
        "pose_change_max_m": float(np.max(shifts)) if shifts else 0.0,
        "edges_skipped": [{"edge": e.to_json(), "reason": r} for e, r in forest.skipped],
        "tolerances": asdict(tol),
    }
