"""``attach``: the staged attachment solver (paper Sec. 3.4 and Appendix 'Attachment and Layout Refinement').

Before the stages, generated meshes are cut where they reach through the floor or a wall beyond their points,
where a parent is taller than what stands on it, and where two of them overlap at their registered poses in
space only one was seen in (``trim.py``). Stages, in order: relational layer (floor snap, wall resolution,
wall attachment and object support, all by propagation in topological order), room/wall repair (near-wall snap, outside repair, bed-wall,
cabinet corner, then generated children re-seated on their parents' faces), then depenetration and a last containment check,
and (after the branches are merged) each generated object's step back toward its registered place as far as
its contacts allow (``restore.py``). ``AttachmentConfig.stop_after`` ends
the run after 'relations' or 'repair' (the ablation of the paper's Table 3(c)).

Dual attachment (``dual_attachment``): the wall-aware branch uses every edge and the wall refinements;
the floor-only branch leaves ``mounts-on wall`` edges and the wall refinements out. Per group (an object
on a structural root together with everything it carries) the wall-aware result is kept unless
  (a) the group holds a ``mounts-on wall`` edge with confidence below ``wall_confidence_min``, or
  (b) in the wall-aware result the group has more problems than in the floor-only result, counting
      collisions, out-of-room objects and, for the floor-only result, every ``mounts-on wall`` edge of
      the group (that branch leaves them unattached by construction), so a confident wall mount is not
      traded for a single collision.
When any group takes the floor-only result, depenetration and the containment check run once more on
the merged layout.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.completions import add_bases, add_tipping_bases, add_wall_bases, planes_within_room
from rescene_core.assembly.depenetrate import depenetrate
from rescene_core.assembly.graph import build_forest
from rescene_core.assembly.objects import AssemblyObject, check_object
from rescene_core.assembly.operations import Operation
from rescene_core.assembly.propagate import propagate
from rescene_core.assembly.refine import (
    bed_wall,
    cabinet_corner,
    find_unfit,
    is_outside,
    near_wall_snap,
    outside_repair,
    reseat_children,
)
from rescene_core.assembly.restore import restore_toward_evidence
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.trim import (
    cut_overlaps,
    cut_registered_overlaps,
    room_cuts,
    seat_cuts,
    top_cuts,
    trimmed,
)
from rescene_core.assembly.wall_evidence import turn_to_wall_evidence
from rescene_core.config import AttachmentConfig
from rescene_core.geometry.sim3 import apply
from rescene_core.records import (
    CompletionKind,
    InstanceId,
    Layout,
    Missing,
    Relation,
    RoomShell,
    Root,
    SceneGraph,
    Stage,
)


def run_branch(state: LayoutState, world: CollisionWorld, use_walls: bool) -> LayoutState:
    """Run the stages on ``state`` in place (see the module docstring) and return it."""
    cfg = state.config
    propagate(state, use_walls=use_walls)
    if cfg.stop_after == "relations":
        return state
    walls_ok = use_walls and bool(state.room.walls)
    if walls_ok and cfg.near_wall_snap:
        near_wall_snap(state)
    outside_repair(state)
    if walls_ok and cfg.bed_wall:
        bed_wall(state)
    if walls_ok and cfg.cabinet_corner:
        cabinet_corner(state)
    reseat_children(state)
    if cfg.stop_after == "repair":
        return state
    depenetrate(state, world)
    outside_repair(state, "final containment")
    return state


def _group_scores(state: LayoutState, world: CollisionWorld) -> dict[InstanceId, int]:
    """Collisions (non-related pairs) plus out-of-room objects per group root."""
    forest = state.forest
    score: dict[InstanceId, int] = defaultdict(int)
    for a, b in world.colliding_pairs({i: state.pose(i) for i in state.objects}, skip=forest.related):
        score[forest.root_of(a)] += 1
        score[forest.root_of(b)] += 1
    for i in state.objects:
        if is_outside(state, i):
            score[forest.root_of(i)] += 1
    return score


def choose_branches(wall: LayoutState, floor: LayoutState, world: CollisionWorld) -> LayoutState:
    """Merge the two branches per group by the rule in the module docstring."""
    cfg, forest = wall.config, wall.forest
    merged = wall.copy("dual")
    merged.operations = wall.operations + floor.operations
    wall_score, floor_score = _group_scores(wall, world), _group_scores(floor, world)
    groups: dict[InstanceId, list[InstanceId]] = defaultdict(list)
    for i in wall.objects:
        groups[forest.root_of(i)].append(i)
        edge = forest.edges.get(i)
        if edge is not None and edge.relation is Relation.MOUNTS_ON and edge.parent is Root.WALL:
            floor_score[forest.root_of(i)] += 1
    switched = False
    for root, members in sorted(groups.items()):
        weak = [
            int(i)
            for i in members
            if i in forest.edges
            and forest.edges[i].relation is Relation.MOUNTS_ON
            and forest.edges[i].parent is Root.WALL
            and forest.edges[i].confidence < cfg.wall_confidence_min
        ]
        worse = wall_score[root] > floor_score[root]
        differs = any(not np.allclose(wall.delta[i], floor.delta[i], atol=1e-9) for i in members)
        if differs and (weak or worse):
            reason = (
                f"wall edge confidence below {cfg.wall_confidence_min} for {weak}"
                if weak
                else f"wall-aware score {wall_score[root]} > floor-only score {floor_score[root]}"
            )
            for i in members:
                merged.delta[i] = floor.delta[i].copy()
                merged._version[i] += 1
                merged.wall_of.pop(i, None)
                merged.completions.pop(i, None)
                merged.base_wanted.pop(i, None)
                merged.support_base_wanted.pop(i, None)
                merged.wall_base_wanted.pop(i, None)
                if i in floor.completions:
                    merged.completions[i] = list(floor.completions[i])
                if i in floor.base_wanted:
                    merged.base_wanted[i] = floor.base_wanted[i]
                if i in floor.support_base_wanted:
                    merged.support_base_wanted[i] = floor.support_base_wanted[i]
            merged.log(root, "dual attachment", "keep floor-only", reason=reason, members=[int(i) for i in members])
            switched = True
        elif differs:
            merged.log(
                root, "dual attachment", "keep wall-aware", wall_score=wall_score[root], floor_score=floor_score[root]
            )
    if switched and cfg.stop_after == "full":
        depenetrate(merged, world, "depenetration (merged)")
        outside_repair(merged, "final containment (merged)")
    return merged


def record_completions(state: LayoutState) -> None:
    """One operation per completion at the final pose, which exporters and metrics read back
    (``Layout.completions``): a ``support plane`` (a horizontal polygon, world and parent-asset frame, its
    height above the floor, the children standing on it), a ``base`` (a convex solid's points) or a ``cut``
    (a plane the generated mesh was cut at before the rules ran, ``trim.room_cuts``)."""
    children: dict[InstanceId, list[int]] = defaultdict(list)
    for op in state.operations:
        if op.details.get("support_plane") and op.branch in (state.branch, "wall-aware", "floor-only"):
            children[InstanceId(int(op.details["parent"]))].append(int(op.instance or 0))
    for i, completions in sorted(state.completions.items()):
        pose = state.pose(i)
        for c in completions:
            world = apply(pose, c.points_asset)
            if c.kind is CompletionKind.CUT:
                state.log(i, "completions", c.kind.value, points_asset=c.points_asset, source=c.source)
                continue
            if c.kind is CompletionKind.BASE:
                state.log(
                    i,
                    "completions",
                    c.kind.value,
                    points_asset=c.points_asset,
                    source=c.source,
                    height_m=float(state.room.floor_distance(world).max()),
                )
                continue
            on = sorted({k for k in children.get(i, []) if state.forest.edges.get(InstanceId(k)) is not None})
            state.log(
                i,
                "completions",
                c.kind.value,
                height_m=float(state.room.floor_distance(world).mean()),
                polygon_world=world,
                polygon_asset=c.points_asset,
                children=on,
                source=c.source,
            )


def attach(objects: dict[int, AssemblyObject], graph: SceneGraph, shell: RoomShell, config: AttachmentConfig) -> Layout:
    """Place every object: compile the graph's relations, propagate, repair and depenetrate.

    objects: instance id -> AssemblyObject (asset-frame mesh and registered world_from_asset).
    Returns a Layout with world_from_asset [4, 4] per placed object (T_hat_i = Delta T_i T_i), every
    operation applied (object, branch, stage, rule, transform) and the objects that could not be placed
    (as Missing). Raises AssemblyError only when the room's floor plane is unusable.
    """
    room = room_from_shell(shell)
    valid: dict[InstanceId, AssemblyObject] = {}
    missing: list[Missing] = []
    for key, obj in sorted(objects.items()):
        problems = check_object(obj)
        if int(key) != int(obj.instance):
            problems.append(f"dict key {key} differs from the object's instance id {obj.instance}")
        if problems:
            missing.append(Missing(InstanceId(int(key)), Stage.ATTACHMENT, "; ".join(problems)))
        else:
            valid[InstanceId(int(key))] = obj
    valid, turned = turn_to_wall_evidence(valid, graph, room, config)
    cuts = {i: room_cuts(obj, room) for i, obj in valid.items()} if config.trim_completions else {}
    valid = {i: trimmed(obj, cuts.get(i, [])) for i, obj in valid.items()}
    forest = build_forest(graph, set(valid))
    seats: dict[InstanceId, float] = {}
    if config.trim_completions:
        for i, cut in top_cuts(valid, forest, room).items():
            cuts.setdefault(i, []).append(cut)
            valid[i] = trimmed(valid[i], [cut])
        for i, seat in seat_cuts(valid, forest, room, seats).items():
            cuts.setdefault(i, []).extend(seat)
            valid[i] = trimmed(valid[i], seat)
    base = LayoutState(valid, forest, room, config, seen_seats=seats)
    for i, info in turned:
        base.log(i, "wall evidence", "turn onto the side its points show", **info)
    for i in sorted(cuts):
        for cut in cuts[i]:
            base.add_completion(cut)
    if config.trim_completions:
        cut_registered_overlaps(base)  # trims base.objects, which is ``valid``
    base.unfit = find_unfit(base)
    for i in sorted(base.unfit):
        base.log(i, "input", "note", reason="footprint cannot fit inside the room; repairs leave it in place")
    for note in room.notes:
        base.operations.append(Operation(None, "all", "input", "note", {"reason": note}))
    for edge, reason in forest.skipped:
        base.log(edge.child, "input", "skip edge", reason=reason, edge=edge.to_json())
    world = CollisionWorld(valid)
    wall_state = run_branch(base.copy("wall-aware"), world, use_walls=True)
    if config.dual_attachment:
        floor_state = run_branch(base.copy("floor-only"), world, use_walls=False)
        floor_state.operations = floor_state.operations[len(base.operations) :]
        final = choose_branches(wall_state, floor_state, world)
    else:
        final = wall_state
    if config.restore_toward_evidence and config.stop_after == "full":
        restore_toward_evidence(final, world)
    if config.trim_completions and config.stop_after == "full":
        cut_overlaps(final, world)
    add_bases(final)
    add_wall_bases(final)
    add_tipping_bases(final)
    planes_within_room(final)
    record_completions(final)
    return Layout(
        world_from_asset={i: final.pose(i) for i in valid},
        operations=tuple(final.operations),
        missing=tuple(missing),
    )
