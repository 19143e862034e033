"""An instance a stage could not handle, with the stage and the reason."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rescene_core.records.ids import InstanceId, Stage


@dataclass(frozen=True)
class Missing:
    """An instance a stage could not handle: later stages skip it, and the report lists it.

    stage: a ``Stage`` (a plain stage name such as ``"registration"`` is converted on construction).
    """

    instance: InstanceId
    stage: Stage
    reason: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "stage", Stage(self.stage))

    def to_json(self) -> dict[str, Any]:
        return {"instance": int(self.instance), "stage": self.stage.value, "reason": self.reason}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Missing:
        return cls(InstanceId(int(d["instance"])), Stage(d["stage"]), str(d["reason"]))
