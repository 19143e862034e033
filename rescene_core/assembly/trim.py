"""Cut a generated mesh's completion where it reaches through the floor or a wall and its points do not.

A single-view completion is often deeper or taller than its object (a desk 0.17 m too deep, a sofa 0.1 m
too tall). Registered on the object's points, its seen side is where the capture saw it and the surplus
pokes through the wall behind it or the floor below it. The rules would repair such a crossing by moving
the whole object off its points (a footprint step of 5 cm away from the wall, a floor snap lifting it
6 cm), although the capture saw the wall and the floor and nothing of the object beyond them: the surplus
is the generator's, not the pose's. So before the rules run, each generated asset with observed points is
cut at the floor and at every wall whose segment it stands in front of, where its mesh reaches more than
TRIM_MARGIN beyond both the boundary and its own points (the cut plane lies at the boundary, or at the
points' own reach when registration put some of them beyond it). The cut keeps the side facing into the
room, capped so a closed mesh stays closed, and is a ``Completion`` of kind ``cut`` in the object's asset
frame, so exporters and metrics cut the same mesh. A cut that would keep less than MIN_KEPT_SHARE of the
mesh's extent across the plane is not made: then the pose, not the completion, is wrong, and the rules
repair it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from rescene_core.assembly.objects import AssemblyObject
from rescene_core.assembly.room import Room
from rescene_core.geometry.completion import cut_mesh
from rescene_core.geometry.sim3 import apply, inverse
from rescene_core.records import Completion, CompletionKind

TRIM_MARGIN = 0.01
"""How far (m) a mesh must reach beyond a boundary, and beyond its own points, to be cut."""
POINTS_REACH_PERCENTILE = 1.0
"""The points' reach towards a boundary is this percentile of their distances to it (stray points aside)."""
MIN_KEPT_SHARE = 0.5
"""Smallest share of the mesh's extent across a cut plane the cut may keep."""
MIN_POINTS = 20
"""Fewest observed points for a cut (fewer say too little about where the object ends)."""


def _plane(reach_points: float, distances_mesh: NDArray, span: float) -> float | None:
    """Signed distance (m, from the boundary, positive inside) of the cut plane, or None: no cut."""
    level = min(0.0, reach_points)
    deepest = float(distances_mesh.min())
    if deepest >= level - TRIM_MARGIN:
        return None
    if float(distances_mesh.max()) - level < MIN_KEPT_SHARE * span:
        return None
    return level


def room_cuts(obj: AssemblyObject, room: Room) -> list[Completion]:
    """The cuts of a generated asset with points at its registered pose (module docstring); [] for exact
    shapes and objects without enough points."""
    if obj.exact_shape or obj.points is None or len(obj.points) < MIN_POINTS:
        return []
    pose = np.asarray(obj.world_from_asset, np.float64)
    verts = obj.world_vertices()
    pts = np.asarray(obj.points, np.float64)
    cuts: list[tuple[NDArray, NDArray, str]] = []
    heights = room.floor_distance(verts)
    level = _plane(
        float(np.percentile(room.floor_distance(pts), POINTS_REACH_PERCENTILE)), heights, float(np.ptp(heights))
    )
    if level is not None:
        origin = verts[int(np.argmin(heights))] + (level - float(heights.min())) * room.up
        cuts.append((origin, room.up, "floor"))
    for wall in room.walls:
        along = wall.along(verts)
        if along.max() <= 0.0 or along.min() >= wall.length:
            continue  # not in front of this wall's segment
        dist = wall.distance(verts)
        level = _plane(float(np.percentile(wall.distance(pts), POINTS_REACH_PERCENTILE)), dist, float(np.ptp(dist)))
        if level is None:
            continue
        origin = verts[int(np.argmin(dist))] + (level - float(dist.min())) * wall.normal
        cuts.append((origin, wall.normal, f"wall {wall.id}"))
    out = []
    to_asset = inverse(pose)
    for origin, normal, what in cuts:
        ends = apply(to_asset, np.stack([origin, origin + normal]))
        direction = ends[1] - ends[0]
        ends[1] = ends[0] + direction / np.linalg.norm(direction)
        out.append(
            Completion(
                obj.instance,
                CompletionKind.CUT,
                ends,
                f"the generated mesh reaches through the {what} beyond the object's observed points: cut there",
            )
        )
    return out


def trimmed(obj: AssemblyObject, cuts: list[Completion]) -> AssemblyObject:
    """``obj`` with its mesh cut at ``cuts`` (the asset frame and pose unchanged)."""
    if not cuts:
        return obj
    vertices, faces = cut_mesh(obj.vertices, obj.faces, cuts)
    return replace(obj, vertices=vertices, faces=faces)
