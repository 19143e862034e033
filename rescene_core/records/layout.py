"""The attachment result: final poses, the operations that produced them, the completions it found."""

from __future__ import annotations

import enum
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.records.ids import InstanceId
from rescene_core.records.missing import Missing


class CompletionKind(enum.StrEnum):
    """What a ``Completion`` adds to an object's mesh."""

    SUPPORT_PLANE = "support plane"
    """A horizontal polygon [k, 3] a child stands on (a shelf board the generated mesh lacks)."""
    BASE = "base"
    """The vertices [k, 3] of a convex solid between the floor and the mesh's lowest part (a leg, a plinth
    the generated mesh lacks)."""
    CUT = "cut"
    """A plane [2, 3] (a point on it and that point plus the normal, asset frame) the mesh is cut at,
    keeping the side the normal points to: a completion reaching through the floor or a wall the capture
    saw, where none of the object's points are."""


HEAD = ("instance", "branch", "stage", "rule")
"""The keys every operation has, first in its JSON form."""


def json_value(value: Any) -> Any:
    """A JSON-ready copy of a detail value: arrays as nested lists and floats rounded to 1e-9."""
    if isinstance(value, np.ndarray):
        value = np.asarray(value, dtype=np.float64) if value.ndim == 2 else value
        return np.round(value, 9).tolist()
    if isinstance(value, np.floating | float):
        return round(float(value), 9)
    if isinstance(value, np.integer):
        return int(value)
    return value


@dataclass(frozen=True)
class Operation(Mapping[str, Any]):
    """One solver step on one object (``instance`` None: the whole scene).

    branch: 'wall-aware', 'floor-only', 'dual' or 'all' (dual attachment, solver.py).
    stage: the solver stage ('floor snap', 'object support', 'near-wall snap', 'depenetration', ...).
    rule: what was done ('snap to wall', 'skip', 'skip edge', 'note', 'keep floor-only', ...).
    details: the rule's own figures and reasons, JSON-ready (``transform``: the world-frame [4, 4]
        correction applied, ``reason``: why a rule did not apply, ...).
    """

    instance: int | None
    branch: str
    stage: str
    rule: str
    details: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        clash = set(HEAD) & set(self.details)
        if clash:
            raise ValueError(f"operation details may not use the reserved keys {sorted(clash)}")
        object.__setattr__(self, "details", MappingProxyType({k: json_value(v) for k, v in self.details.items()}))

    # it reads as its JSON form too (op["rule"], op["transform"], "bound_clipped" in op)
    def __getitem__(self, key: str) -> Any:
        if key in HEAD:
            return getattr(self, key)
        return self.details[key]

    def __iter__(self) -> Iterator[str]:
        yield from HEAD
        yield from self.details

    def __len__(self) -> int:
        return len(HEAD) + len(self.details)

    @property
    def reason(self) -> str | None:
        """Why a rule was skipped or a note was made (None for a move)."""
        return self.details.get("reason")

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": self.instance,
            "branch": self.branch,
            "stage": self.stage,
            "rule": self.rule,
            **self.details,
        }

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> Operation:
        instance = d.get("instance")
        return cls(
            None if instance is None else int(instance),
            str(d.get("branch", "")),
            str(d.get("stage", "")),
            str(d.get("rule", "")),
            {k: v for k, v in d.items() if k not in HEAD},
        )


@dataclass(frozen=True)
class Completion:
    """Geometry an object's generated mesh lacks, added by attachment from the object's observed points (or
    from its relation when the points show nothing), so that contacts and colliders agree on it.

    points_asset: float64 [k, 3], asset frame (apply the object's world_from_asset to place it): the
      polygon of a support plane, the vertices of a base (its convex hull is the solid), or a cut plane's
      point and that point plus its normal.
    source: what showed the geometry (a sentence for the layout and the export report).
    """

    instance: InstanceId
    kind: CompletionKind
    points_asset: NDArray[np.float64]
    source: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "kind": self.kind.value,
            "points_asset": np.asarray(self.points_asset, np.float64).tolist(),
            "source": self.source,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Completion:
        return cls(
            InstanceId(int(d["instance"])),
            CompletionKind(d["kind"]),
            np.asarray(d["points_asset"], np.float64).reshape(-1, 3),
            str(d.get("source", "")),
        )


@dataclass(frozen=True)
class Layout:
    """The attachment-optimised layout: final poses and the operations that produced them.

    world_from_asset: per instance, float64 [4, 4] Sim(3), T_hat_i = Delta T_i * T_i.
    operations: one ``Operation`` per solver step, in the order applied (``layout.json``: their JSON form).
    """

    world_from_asset: dict[InstanceId, NDArray[np.float64]]
    operations: tuple[Operation, ...] = ()
    missing: tuple[Missing, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "objects": {str(int(k)): np.asarray(v).tolist() for k, v in self.world_from_asset.items()},
            "operations": [op.to_json() for op in self.operations],
            "missing": [m.to_json() for m in self.missing],
        }

    def completions(self) -> dict[InstanceId, list[Completion]]:
        """Per instance, the geometry attachment added to its mesh (the ``support plane`` and ``base``
        operations, in the order applied)."""
        out: dict[InstanceId, list[Completion]] = {}
        for op in self.operations:
            completion = completion_of_operation(op)
            if completion is not None:
                out.setdefault(completion.instance, []).append(completion)
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Layout:
        return cls(
            {InstanceId(int(k)): np.asarray(v, dtype=np.float64) for k, v in d["objects"].items()},
            tuple(Operation.from_json(op) for op in d.get("operations", ())),
            tuple(Missing.from_json(m) for m in d.get("missing", ())),
        )


def completion_of_operation(op: Operation) -> Completion | None:
    """The Completion a layout operation records (rule ``support plane``: ``polygon_asset``; rules ``base``
    and ``cut``: ``points_asset``), or None for any other operation."""
    if op.rule == CompletionKind.SUPPORT_PLANE.value:
        points = op.details["polygon_asset"]
    elif op.rule in (CompletionKind.BASE.value, CompletionKind.CUT.value):
        points = op.details["points_asset"]
    else:
        return None
    if op.instance is None:
        return None
    return Completion(
        InstanceId(int(op.instance)),
        CompletionKind(op.rule),
        np.asarray(points, np.float64).reshape(-1, 3),
        str(op.details.get("source", "")),
    )
