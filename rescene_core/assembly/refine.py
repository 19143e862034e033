"""Room and wall repairs after the relational layer (paper Appendix 'Attachment and Layout Refinement').

near-wall snap: large floor objects whose back lies within ``near_wall_distance`` of a wall and whose
    nearest horizontal axis is within ``auto_wall_snap_rotation_deg`` of the wall normal are turned
    square to the wall and moved to ``wall_contact_gap`` from it (at most ``auto_wall_snap_translation`` m;
    a gap within ``wall_collision_margin`` is contact and is kept).
outside repair: an object whose footprint leaves the floor polygon (beyond ``containment_tolerance``)
    is moved by the smallest translation that puts it back inside the polygon shrunk by
    ``wall_contact_gap`` (wall-mounted objects: the polygon itself).
bed-wall: beds (``bed_labels``) get the same wall snap with the distance limit raised to
    ``auto_wall_snap_translation``.
cabinet corner: cabinets (``cabinet_labels``) within ``cabinet_corner_translation`` of two
    non-parallel walls are moved into the corner, at most that far.
Every move takes the object's descendants along.
"""

from __future__ import annotations

import numpy as np

from rescene_core.assembly.compile_floor import inner_polygon
from rescene_core.assembly.compile_wall import horizontal_axes
from rescene_core.assembly.evidence import (
    completion_crossing,
    containment_footprint,
    snap_refuses,
    wall_gap,
    yaw_to_direction,
)
from rescene_core.assembly.room import Wall, fit_translation
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import rotation_about, translation
from rescene_core.geometry.sim3 import apply
from rescene_core.records import InstanceId, Relation, Root


def floor_objects(state: LayoutState) -> list[InstanceId]:
    """Objects resting on the floor root."""
    return [c for c, e in state.forest.edges.items() if e.relation is Relation.RESTS_ON and e.parent is Root.FLOOR]


def label_matches(label: str, names: tuple[str, ...]) -> bool:
    words = label.lower().replace("-", " ").replace("_", " ").split()
    return any(n in words or label.lower() == n for n in names)


def _overlaps_segment(wall: Wall, verts: np.ndarray) -> bool:
    along = wall.along(verts)
    return bool(along.max() > 0.0 and along.min() < wall.length)


def contact_push(gap: float, margin: float, contact_gap: float) -> float:
    """Move (m, along the wall's inward normal) of an object whose back is ``gap`` m in front of a wall
    (negative: through it): none when the gap is within [0, ``margin``] (contact), else to ``contact_gap``
    (the smallest correction that makes contact, not a step to the margin)."""
    if 0.0 <= gap <= margin:
        return 0.0
    return contact_gap - gap


def wall_snap(state: LayoutState, i: InstanceId, max_gap: float, max_rot: float, max_move: float, stage: str) -> bool:
    """Turn object i square to its nearest wall and put it in contact with it (``contact_push``)."""
    cfg, room = state.config, state.room
    if i in state.unfit:
        return False
    pose, verts = state.pose(i), state.vertices(i)
    pivot = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
    best = None
    for wall in room.walls:
        if not _overlaps_segment(wall, verts):
            continue
        gap = wall_gap(state, i, wall)
        if gap > max_gap:
            continue
        found = yaw_to_direction(state, i, -wall.normal, horizontal_axes(pose, room.up), max_rot)
        if found is None or abs(found[0]) > max_rot:
            continue
        yaw = found[0]
        if best is None or abs(gap) < abs(best[1]):
            best = (wall, gap, yaw)
    if best is None:
        return False
    wall, gap, yaw = best
    turn = rotation_about(yaw * room.up, pivot)
    turned = apply(turn @ pose, state.objects[i].vertices)
    new_gap = float(wall.distance(turned).min())
    registered = -float(wall.distance(state.objects[i].world_vertices()).min())
    if gap >= 0.0 and completion_crossing(state, i, -new_gap, registered):
        new_gap = 0.0  # generated asset: deep penetration with the centre in front is completion (evidence.py)
    push = contact_push(new_gap, cfg.wall_collision_margin, cfg.wall_contact_gap)
    if abs(push) > max_move:
        state.skip(i, stage, f"wall snap needs {abs(push):.3f} m > {max_move} m")
        return False
    if abs(push) < 1e-6 and abs(yaw) < 1e-9:
        return False
    snap = translation(push * wall.normal) @ turn
    refused = snap_refuses(state, i, snap @ pose)
    if refused is not None:
        state.skip(i, stage, refused)
        return False
    state.move(
        i,
        snap,
        stage,
        "snap to wall",
        wall_id=wall.id,
        yaw_deg=float(np.degrees(yaw)),
        normal_m=push,
    )
    return True


def near_wall_snap(state: LayoutState) -> None:
    cfg = state.config
    for i in floor_objects(state):
        if state.footprint(i).area < cfg.near_wall_min_footprint:
            continue
        wall_snap(
            state,
            i,
            cfg.near_wall_distance,
            np.radians(cfg.auto_wall_snap_rotation_deg),
            cfg.auto_wall_snap_translation,
            "near-wall snap",
        )


def bed_wall(state: LayoutState) -> None:
    cfg = state.config
    for i in floor_objects(state):
        if label_matches(state.objects[i].label, cfg.bed_labels):
            wall_snap(
                state,
                i,
                cfg.auto_wall_snap_translation,
                np.radians(cfg.auto_wall_snap_rotation_deg),
                cfg.auto_wall_snap_translation,
                "bed-wall",
            )


def cabinet_corner(state: LayoutState) -> None:
    cfg, room = state.config, state.room
    for i in floor_objects(state):
        if i in state.unfit or not label_matches(state.objects[i].label, cfg.cabinet_labels):
            continue
        verts = state.vertices(i)
        near = []
        for wall in room.walls:
            gap = wall_gap(state, i, wall)
            if _overlaps_segment(wall, verts) and gap <= cfg.cabinet_corner_translation:
                near.append((gap, wall))
        near.sort(key=lambda gw: gw[0])
        pair = next(
            ((a, b) for k, a in enumerate(near) for b in near[k + 1 :] if abs(a[1].normal @ b[1].normal) < 0.5),
            None,
        )
        if pair is None:
            continue
        (g1, w1), (g2, w2) = pair
        n = np.stack([w1.normal[:2], w2.normal[:2]])
        margin, gap = cfg.wall_collision_margin, cfg.wall_contact_gap
        step2 = np.linalg.solve(n, [contact_push(g1, margin, gap), contact_push(g2, margin, gap)])
        step = np.array([step2[0], step2[1], 0.0])
        if np.linalg.norm(step) > cfg.cabinet_corner_translation:
            state.skip(i, "cabinet corner", f"corner needs {np.linalg.norm(step):.3f} m")
            continue
        if np.linalg.norm(step) <= 1e-6:
            continue
        refused = snap_refuses(state, i, translation(step) @ state.pose(i))
        if refused is not None:
            state.skip(i, "cabinet corner", refused)
            continue
        state.move(i, translation(step), "cabinet corner", "snap into corner", walls=[w1.id, w2.id])


def containment_region(state: LayoutState, i: InstanceId):
    """Where object i's footprint must lie: the polygon for wall-mounted objects, else the polygon shrunk by
    ``wall_contact_gap``."""
    room = state.room
    if i in state.wall_of:
        return room.polygon
    return inner_polygon(room, state.config.wall_contact_gap)


def is_outside(state: LayoutState, i: InstanceId) -> bool:
    room = state.room
    if room.polygon is None:
        return False
    return not containment_footprint(state, i).within(room.polygon.buffer(state.config.containment_tolerance))


def outside_repair(state: LayoutState, stage: str = "outside repair") -> None:
    """Move every object whose footprint leaves the room back inside (parents before children)."""
    if state.room.polygon is None:
        return
    order = list(state.forest.edges) + [i for i in state.objects if i not in state.forest.edges]
    for i in order:
        if i in state.unfit or not is_outside(state, i):
            continue
        edge = state.forest.edges.get(i)
        if edge is not None and not isinstance(edge.parent, Root) and is_outside(state, InstanceId(edge.parent)):
            # its parent was left outside (the correction bound): it stays on its parent
            state.skip(i, stage, f"its parent {int(edge.parent)} is outside the room too; it stays on it")
            continue
        shift = fit_translation(containment_footprint(state, i), containment_region(state, i))
        if shift is None:
            state.skip(i, stage, "footprint is larger than the room; left in place")
            continue
        state.move(i, translation([shift[0], shift[1], 0.0]), stage, "move inside floor polygon")


def find_unfit(state: LayoutState) -> frozenset[InstanceId]:
    """Objects whose current footprint cannot be translated inside the (inset) floor polygon."""
    if state.room.polygon is None:
        return frozenset()
    out = set()
    for i in state.objects:
        region = containment_region(state, i)
        if region is not None and fit_translation(state.footprint(i), region) is None:
            out.add(i)
    return frozenset(out)


RESEAT_MAX_OFFSET = 0.10
"""Farthest (m) a generated child with observed points is re-seated from where it was registered
(horizontally, box centre to box centre): the re-seat puts it back over its registered centre, or the parent's
face grown under it where the capture saw the parent there (``compile_support.extend_under_child``), so a face
farther off belongs to a parent that a repair took away from the child's points (or to a wrong relation), and
the child keeps its registered pose."""


def reseat_offset(state: LayoutState, child: InstanceId, correction: np.ndarray) -> float | None:
    """Horizontal distance (m) between ``child``'s registered bounding-box centre and its centre after
    ``correction`` (world [4, 4]) at its current pose; None for an exact shape or a child without points."""
    obj = state.objects[child]
    if obj.exact_shape or obj.points is None or len(obj.points) == 0:
        return None
    seen = obj.world_vertices()
    now = obj.world_vertices(correction @ state.pose(child))
    step = 0.5 * (now.min(axis=0) + now.max(axis=0)) - 0.5 * (seen.min(axis=0) + seen.max(axis=0))
    step = step - float(step @ state.room.up) * state.room.up
    return float(np.linalg.norm(step))


def reseat_children(state: LayoutState, stage: str = "re-seat children") -> None:
    """Put children resting on objects back on their parents' support faces after the repairs.

    A repair that turns or moves a parent takes its children along (a dining table squared to a wall by
    19 deg swings a monitor near its edge by ~0.4 m), but a child was registered on its own points:
    ``compile_support`` puts it back over its registered centre (or the nearest point of the face) at the
    face's height, unless that would leave its observed points behind (``evidence.evidence_refuses``): then
    it keeps its registered pose, on a support plane at its registered bottom when that lies inside its
    parent (``compile_support.board_at_child``); so does a generated child whose parent's face would put it
    more than RESEAT_MAX_OFFSET from where it was registered. Parents before children."""
    from rescene_core.assembly.compile_support import board_at_child, compile_support
    from rescene_core.assembly.evidence import evidence_refuses

    for child, edge in state.forest.edges.items():
        if isinstance(edge.parent, Root) or edge.relation is not Relation.RESTS_ON:
            continue
        if child in state.unfit:
            continue
        correction, info = compile_support(state, child, edge)
        if correction is None or np.allclose(correction, np.eye(4), atol=1e-6):
            continue
        refused = evidence_refuses(state, child, correction @ state.pose(child))
        off = reseat_offset(state, child, correction)
        if refused is None and off is not None and off > RESEAT_MAX_OFFSET:
            refused = (
                f"its parent's support face lies {off:.2f} m from where its points were seen (more than "
                f"{RESEAT_MAX_OFFSET} m): not re-seated there"
            )
        if refused is not None:  # the relational layer refused this child's face for the same reason
            state.skip(child, stage, refused)
            # nor does it follow its parent's repairs: it stays where it was seen
            back = state.objects[child].world_from_asset @ np.linalg.inv(state.pose(child))
            # back where it was seen: no correction away from the evidence, so the bound does not apply
            state.move(child, back, stage, "keep registered pose", bounded=False, parent=int(edge.parent))
            # where it was seen standing inside its parent, the parent has a shelf its mesh lacks
            if board_at_child(state, InstanceId(edge.parent), child) is not None:
                state.log(
                    child,
                    stage,
                    "on a shelf at its registered bottom",
                    parent=int(edge.parent),
                    support_plane="the child's registered bottom, where it keeps its registered pose",
                )
            continue
        state.move(child, correction, stage, "back on parent's face", parent=int(edge.parent))
