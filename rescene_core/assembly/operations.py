"""``Operation``: one typed record per step of the attachment solver (a move, a skip, a note, a choice).

The solver logs an ``Operation`` for every rule it applies or skips; ``Layout.operations`` (and so
``layout.json``) holds their JSON form, ``{"instance", "branch", "stage", "rule", **details}``, in that key
order. ``operations_of`` reads them back as records.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

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
class Operation:
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


def operations_of(records: Iterable[Mapping[str, Any] | Operation]) -> tuple[Operation, ...]:
    """``Layout.operations`` (JSON form, e.g. read from ``layout.json``) as typed records."""
    return tuple(r if isinstance(r, Operation) else Operation.from_json(r) for r in records)
