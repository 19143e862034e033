"""Mutable working state of one attachment run: per-object adjustments Delta T_i and the operation log.

The correction bound (``AttachmentConfig.max_correction_m``): an object's own horizontal move is that of its
registered bounding-box centre under Delta T_i beyond where its parent's Delta T carries that point (for an
object on the floor or a wall: its whole horizontal move). ``move`` and ``set_delta`` cut a correction that
would take it past the bound (or further past it) to the longest part of the correction that does not, and
record ``bound_clipped`` (wanted and taken metres) in the operation. An object in collision is not bounded:
depenetration, which only moves objects in collision with others, passes ``bounded=False``, and an object
reaching behind an observed wall (``through_wall``) is moved out in full."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from rescene_core.assembly.graph import Forest
from rescene_core.assembly.objects import AssemblyObject, footprint
from rescene_core.assembly.operations import Operation
from rescene_core.assembly.room import Room
from rescene_core.assembly.transforms import translation
from rescene_core.config import AttachmentConfig
from rescene_core.records import Completion, InstanceId, Root


@dataclass
class LayoutState:
    """Objects, their registered poses T_i, the world-frame adjustments Delta T_i, and what was done.

    pose(i) = delta[i] @ T_i (paper: T_hat_i = Compose(Delta T_i, T_i)). Moving an object moves its
    whole subtree in the forest, so descendants keep their place relative to their parents.
    """

    objects: dict[InstanceId, AssemblyObject]
    forest: Forest
    room: Room
    config: AttachmentConfig
    branch: str = "wall-aware"
    delta: dict[InstanceId, NDArray[np.float64]] = field(default_factory=dict)
    operations: list[Operation] = field(default_factory=list)
    wall_of: dict[InstanceId, int] = field(default_factory=dict)
    """Concrete wall each wall-mounted object was attached to."""
    unfit: frozenset[InstanceId] = frozenset()
    """Objects whose footprint cannot fit inside the room: no repair or depenetration moves them."""
    completions: dict[InstanceId, list[Completion]] = field(default_factory=dict)
    """Geometry a generated mesh lacks, added from evidence: support planes (shelf boards, in the parent's
    asset frame; compile_support) per parent, as they are found."""
    base_wanted: dict[InstanceId, str] = field(default_factory=dict)
    """Objects resting on the floor whose mesh the evidence keeps above it (a generated mesh lacking its
    lower part), with the reason: they get a base at their final pose (completions.add_bases)."""
    support_base_wanted: dict[InstanceId, tuple[InstanceId, float, str]] = field(default_factory=dict)
    """Objects resting on another whose support correction the evidence refused while their observed points
    reach down to it (a lamp whose generated mesh lacks its stem): the parent, the support level (m above
    the parent's lowest point) and the reason; they get a base down to that level (completions.add_bases)."""
    wall_base_wanted: dict[InstanceId, tuple[int, str]] = field(default_factory=dict)
    """Objects mounted on a wall whose wall correction the evidence refused (a generated mesh that is the front
    of a wall cabinet seen from below, its back never seen): the wall and the reason; they get a base back to
    that wall when their points reach it (completions.add_wall_bases)."""
    seen_seats: dict[InstanceId, float] = field(default_factory=dict)
    """Generated children whose mesh was cut at the top their support was seen with around them
    (``trim.seat_cuts``): that top's height (m above the floor), where the support rule seats them."""
    _cache: dict[InstanceId, tuple[int, NDArray[np.float64]]] = field(default_factory=dict)
    _version: dict[InstanceId, int] = field(default_factory=dict)
    _anchor: dict[InstanceId, NDArray[np.float64]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for i in self.objects:
            self.delta.setdefault(i, np.eye(4))
            self._version.setdefault(i, 0)

    def copy(self, branch: str | None = None) -> LayoutState:
        return LayoutState(
            self.objects,
            self.forest,
            self.room,
            self.config,
            branch or self.branch,
            {k: v.copy() for k, v in self.delta.items()},
            list(self.operations),
            dict(self.wall_of),
            self.unfit,
            {k: list(v) for k, v in self.completions.items()},
            dict(self.base_wanted),
            dict(self.support_base_wanted),
            dict(self.wall_base_wanted),
            dict(self.seen_seats),
        )

    def add_completion(self, completion: Completion) -> None:
        """Record ``completion`` once (an identical one found again by the other branch or edge is kept once)."""
        known = self.completions.setdefault(completion.instance, [])
        same = (c for c in known if c.kind is completion.kind and c.points_asset.shape == completion.points_asset.shape)
        if not any(np.allclose(c.points_asset, completion.points_asset, atol=1e-9) for c in same):
            known.append(completion)

    def replace_object(self, obj: AssemblyObject) -> None:
        """Put ``obj`` in place of the object with its instance id (a cut mesh; same asset frame and pose)."""
        self.objects[obj.instance] = obj
        self._version[obj.instance] += 1

    def pose(self, i: InstanceId) -> NDArray[np.float64]:
        """Current world_from_asset [4, 4] of object i."""
        return self.delta[i] @ self.objects[i].world_from_asset

    def vertices(self, i: InstanceId) -> NDArray[np.float64]:
        """Current world vertices [v, 3] of object i (cached until it moves)."""
        version = self._version[i]
        hit = self._cache.get(i)
        if hit is None or hit[0] != version:
            hit = (version, self.objects[i].world_vertices(self.pose(i)))
            self._cache[i] = hit
        return hit[1]

    def footprint(self, i: InstanceId) -> Polygon:
        return footprint(self.vertices(i))

    def centre(self, i: InstanceId) -> NDArray[np.float64]:
        """Centre [3] of the current world bounding box of object i (m)."""
        v = self.vertices(i)
        return 0.5 * (v.min(axis=0) + v.max(axis=0))

    def own_move(self, i: InstanceId, delta: NDArray | None = None) -> NDArray[np.float64]:
        """Horizontal move [3] (m) of object i's registered bounding-box centre under ``delta`` (default: its
        current Delta T_i) beyond where its parent's Delta T carries that point."""
        anchor = self._anchor.get(i)
        if anchor is None:
            v = self.objects[i].world_vertices()
            anchor = self._anchor[i] = np.append(0.5 * (v.min(axis=0) + v.max(axis=0)), 1.0)
        carried = self.carried(i)
        own = ((self.delta[i] if delta is None else np.asarray(delta)) @ anchor - carried @ anchor)[:3]
        up = self.room.up
        return own - float(own @ up) * up

    def carried(self, i: InstanceId) -> NDArray[np.float64]:
        """The Delta T [4, 4] object i's parent carries it by (identity on the floor or a wall)."""
        edge = self.forest.edges.get(i)
        parent = None if edge is None or isinstance(edge.parent, Root) else InstanceId(int(edge.parent))
        return self.delta[parent] if parent is not None and parent in self.delta else np.eye(4)

    def through_wall(self, i: InstanceId, verts: NDArray | None = None) -> bool:
        """Whether object i (its world vertices ``verts`` [v, 3], default its current ones) reaches more than
        ``wall_collision_margin`` behind an observed wall within the wall's segment: in collision with it."""
        verts = self.vertices(i) if verts is None else np.asarray(verts)
        margin = self.config.wall_collision_margin
        for wall in self.room.walls:
            behind = wall.distance(verts) < -margin
            if behind.any():
                along = wall.along(verts[behind])
                if bool(((along >= 0.0) & (along <= wall.length)).any()):
                    return True
        return False

    def bounded(self, i: InstanceId, correction: NDArray) -> tuple[NDArray[np.float64], dict[str, float] | None]:
        """``correction`` [4, 4] (world frame) of object i cut to the correction bound (module docstring), and
        what the cut took away (None: nothing)."""
        limit = self.config.max_correction_m
        correction = np.asarray(correction, np.float64)
        if limit is None or self.through_wall(i):
            return correction, None
        before = self.own_move(i)
        after = self.own_move(i, correction @ self.delta[i])
        step = after - before
        reach = max(limit, float(np.linalg.norm(before)))
        if float(np.linalg.norm(after)) <= reach + 1e-9:
            return correction, None
        # the largest s in [0, 1] with |before + s step| <= reach
        a, b, c = float(step @ step), 2.0 * float(before @ step), float(before @ before) - reach**2
        s = float(np.clip((-b + np.sqrt(max(b * b - 4 * a * c, 0.0))) / (2 * a), 0.0, 1.0)) if a > 0 else 0.0
        clip = {
            "wanted_m": float(np.linalg.norm(step)),
            "taken_m": s * float(np.linalg.norm(step)),
            "max_correction_m": float(limit),
        }
        return translation(-(1.0 - s) * step) @ correction, clip

    def move(
        self, i: InstanceId, correction: NDArray, stage: str, rule: str, bounded: bool = True, **info: Any
    ) -> None:
        """Apply the world-frame ``correction`` [4, 4] to object i and all its descendants, and log it.
        bounded: cut the correction to the correction bound (module docstring); False for moves that
        separate objects in collision."""
        if bounded:
            correction, clip = self.bounded(i, correction)
            if clip is not None:
                info["bound_clipped"] = clip
                if np.allclose(correction, np.eye(4), atol=1e-9):
                    self.log(
                        i,
                        stage,
                        "skip",
                        reason=f"{rule}: the object has already moved max_correction_m = {clip['max_correction_m']} "
                        f"m of its own; the {clip['wanted_m']:.3f} m move is not taken",
                        **info,
                    )
                    return
        if np.allclose(correction, np.eye(4), atol=1e-12):
            return
        moved = self.forest.subtree(i)
        for j in moved:
            self.delta[j] = correction @ self.delta[j]
            self._version[j] += 1
        self.log(i, stage, rule, transform=correction, moved=[int(j) for j in moved], **info)

    @contextmanager
    def trial(self, i: InstanceId, correction: NDArray) -> Iterator[list[InstanceId]]:
        """Apply the world-frame ``correction`` [4, 4] to object i and its descendants for the duration of the
        block (yields them), then undo it; nothing is logged."""
        moved = self.forest.subtree(i)
        saved = {j: self.delta[j] for j in moved}
        for j in moved:
            self.delta[j] = correction @ self.delta[j]
            self._version[j] += 1
        try:
            yield moved
        finally:
            for j in moved:
                self.delta[j] = saved[j]
                self._version[j] += 1

    def over_bound(self, i: InstanceId, delta: NDArray) -> dict[str, float] | None:
        """What the correction bound would cut from Delta T_i = ``delta`` [4, 4] (a propagated correction):
        {wanted_m, taken_m, max_correction_m}, or None when the object's own horizontal move is within the
        bound, the bound is off, or the object, where its parent carries it, reaches behind a wall."""
        limit = self.config.max_correction_m
        if limit is None:
            return None
        length = float(np.linalg.norm(self.own_move(i, delta)))
        if length <= limit + 1e-9:
            return None
        carried = self.objects[i].world_vertices(self.carried(i) @ self.objects[i].world_from_asset)
        if self.through_wall(i, carried):
            return None
        return {"wanted_m": length, "taken_m": float(limit), "max_correction_m": float(limit)}

    def set_delta(self, i: InstanceId, delta: NDArray, stage: str, rule: str, **info: Any) -> None:
        """Set Delta T_i directly (propagation), logging the change; the object's own horizontal move is cut
        to the correction bound (module docstring)."""
        delta = np.asarray(delta, dtype=np.float64)
        over = self.over_bound(i, delta)
        if over is not None:
            limit = float(over["max_correction_m"])
            own = self.own_move(i, delta)
            delta = translation(-(1.0 - limit / float(np.linalg.norm(own))) * own) @ delta
            info["bound_clipped"] = over
        self.delta[i] = delta
        self._version[i] += 1
        self.log(i, stage, rule, **info)

    def log(self, i: InstanceId | None, stage: str, rule: str, **info: Any) -> None:
        """Record an operation on object i (None: the whole scene) in this branch."""
        self.operations.append(Operation(None if i is None else int(i), self.branch, stage, rule, info))

    def skip(self, i: InstanceId, stage: str, reason: str) -> None:
        """Record that a rule did not apply to object i, and why."""
        self.log(i, stage, "skip", reason=reason)
