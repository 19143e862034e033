"""Built-in structure: objects the simulation exports fix to the world although nothing mounts them.

A fitted kitchen's counters and the shelves of an apartment's fixed units stand on the floor, are fastened
to a wall and carry things on a large horizontal top. The scene graph says ``rests-on floor`` for them
(what the capture shows), and a free body there can be pushed, tipped or sent sliding by what stands on
it, which the room it came from never does. An object is built-in structure when all of these hold:

* its label is one of ``ExportConfig.structure_labels`` (compared without case or surrounding spaces):
  built-in names (counter, worktop) and the names a label-free segmentation gives (``object``, empty);
  a labelled piece of movable furniture (a desk, a dresser, a sideboard) stays free whatever its shape;
* it rests on the floor (scene graph);
* its top lies ``structure_top_height_m`` above the floor (a counter's or a fitted shelf unit's work
  height), the top of its mesh or of a completion attachment gave it;
* it backs onto an observed wall: its geometry comes within ``structure_wall_gap_m`` of the wall's plane,
  alone or in a run of such objects along that wall (each starting within the same gap of where the
  previous one ends: the units of a fitted kitchen) at least ``structure_min_length_m`` long (a fitted
  run, not a stool or a single cabinet by a wall).

The thresholds are the project's choices (the paper is silent): docs/export.md.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.export.objects import ExportObject
from rescene_core.geometry.sim3 import apply
from rescene_core.records import CompletionKind, InstanceId, Relation, RoomShell, Root, SceneGraph


@dataclass(frozen=True)
class StructureRule:
    """The thresholds of the module docstring (from ExportConfig)."""

    labels: tuple[str, ...] = ("", "object", "unknown", "counter", "countertop", "kitchen counter", "worktop")
    top_height_m: tuple[float, float] = (0.6, 1.2)
    wall_gap_m: float = 0.05
    min_length_m: float = 1.0


def world_geometry(obj: ExportObject) -> NDArray[np.float64]:
    """World points [n, 3] of an exported object's mesh and of its ``base`` and ``support plane``
    completions."""
    pose = np.asarray(obj.world_from_asset, np.float64)
    parts = [apply(pose, np.asarray(obj.vertices, np.float64))]
    for c in obj.completions:
        if c.kind in (CompletionKind.BASE, CompletionKind.SUPPORT_PLANE):
            parts.append(apply(pose, np.asarray(c.points_asset, np.float64)))
    return np.vstack(parts)


def _candidate(
    obj: ExportObject, graph: SceneGraph, shell: RoomShell, rule: StructureRule
) -> tuple[float, dict[int, tuple[float, float]]] | None:
    """The top height (m above the floor) of an object that may be built-in structure and, per wall it backs
    onto, the interval (m along the wall's segment) where it comes within the gap; None when its label,
    relation or top rules it out or it backs onto no wall."""
    if obj.label.strip().lower() not in {label.strip().lower() for label in rule.labels}:
        return None
    edge = graph.parent_of().get(InstanceId(int(obj.instance)))
    if edge is None or edge.relation is not Relation.RESTS_ON or edge.parent is not Root.FLOOR:
        return None
    world = world_geometry(obj)
    top = float(shell.floor.signed_distance(world).max())
    lo, hi = rule.top_height_m
    if not lo <= top <= hi:
        return None
    spans = {}
    for wall in shell.walls:
        start, end = np.asarray(wall.segment, np.float64)
        length = float(np.linalg.norm(end - start))
        near = world[wall.plane.signed_distance(world) <= rule.wall_gap_m]
        if length <= 0 or not len(near):
            continue
        along = np.clip((near[:, :2] - start) @ ((end - start) / length), 0.0, length)
        if np.ptp(along) > 0:
            spans[wall.id] = (float(along.min()), float(along.max()))
    return (top, spans) if spans else None


def built_in(
    objects: Iterable[ExportObject], graph: SceneGraph | None, shell: RoomShell | None, rule: StructureRule
) -> dict[int, str]:
    """Per instance that is built-in structure (module docstring), why: a run of candidates along one wall
    (each backing onto it, the next starting within ``wall_gap_m`` of where the last ends) at least
    ``min_length_m`` long makes every member built-in (the units of a fitted kitchen, each shorter than
    the run)."""
    if shell is None or not shell.walls or graph is None:
        return {}
    found = {int(o.instance): (o, c) for o in objects if (c := _candidate(o, graph, shell, rule)) is not None}
    out: dict[int, str] = {}
    for wall in shell.walls:
        along = sorted((c[1][wall.id], i) for i, (_, c) in found.items() if wall.id in c[1])
        runs: list[tuple[float, float, list[int]]] = []
        for (a, b), i in along:
            if runs and a <= runs[-1][1] + rule.wall_gap_m:
                runs[-1] = (runs[-1][0], max(runs[-1][1], b), [*runs[-1][2], i])
            else:
                runs.append((a, b, [i]))
        for a, b, members in runs:
            if b - a < rule.min_length_m:
                continue
            for i in members:
                obj, (top, _) = found[i]
                out.setdefault(
                    i,
                    f"built-in structure: labelled {obj.label!r}, resting on the floor, its top {top:.2f} m up, "
                    f"one of {len(members)} backed onto wall {wall.id} along {b - a:.2f} m: fixed to the world",
                )
    return out
