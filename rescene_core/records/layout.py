"""The attachment result: final poses, the operations that produced them, the completions it found."""

from __future__ import annotations

import enum
from dataclasses import dataclass
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
    operations: one record per operation applied ({"instance", "rule", "transform", ...}).
    """

    world_from_asset: dict[InstanceId, NDArray[np.float64]]
    operations: tuple[dict[str, Any], ...] = ()
    missing: tuple[Missing, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "objects": {str(int(k)): np.asarray(v).tolist() for k, v in self.world_from_asset.items()},
            "operations": list(self.operations),
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
            tuple(d.get("operations", ())),
            tuple(Missing.from_json(m) for m in d.get("missing", ())),
        )


def completion_of_operation(op: dict[str, Any]) -> Completion | None:
    """The Completion a layout operation records (rule ``support plane``: ``polygon_asset``; rules ``base``
    and ``cut``: ``points_asset``), or None for any other operation."""
    rule = op.get("rule")
    if rule == CompletionKind.SUPPORT_PLANE.value:
        points = op["polygon_asset"]
    elif rule in (CompletionKind.BASE.value, CompletionKind.CUT.value):
        points = op["points_asset"]
    else:
        return None
    return Completion(
        InstanceId(int(op["instance"])),
        CompletionKind(rule),
        np.asarray(points, np.float64).reshape(-1, 3),
        str(op.get("source", "")),
    )
