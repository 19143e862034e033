"""What a stage returns: a reference to the file it wrote, its hash, status and a few numbers."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

from rescene_core.records.ids import InstanceId
from rescene_core.records.missing import Missing


class RefStatus(enum.StrEnum):
    """Whether a stage produced its output for the item (``OK``) or an explicit Missing (``MISSING``)."""

    OK = "ok"
    MISSING = "missing"


@dataclass(frozen=True)
class Ref:
    """What a pipeline task returns: a small reference to the file it wrote, never the data itself.

    kind: what the file holds ("shell", "view", "asset", "pose", "graph", "layout", "scene", ...).
    path: the file, relative to the run directory (absolute for the capture, which lives outside it).
    sha256: content hash of that file (of the whole Zarr store for the capture, of every file under scene/ for
      the export's reference to scene.json).
    item: the instance id or key-frame index, None for scene-level outputs.
    status: OK, or MISSING when the stage recorded ``missing`` instead of an output.
    numbers: a few plain JSON numbers for tables and logs (faces, frame, rmse, ...).
    detail: small JSON values a later stage needs (the key-frame list, the export's file hashes).

    Only ``cache_digest()`` enters the cache keys of the tasks that take this reference as input.
    """

    kind: str
    path: str
    sha256: str
    item: int | None = None
    status: RefStatus = RefStatus.OK
    numbers: dict[str, Any] = field(default_factory=dict)
    missing: Missing | None = None
    detail: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", RefStatus(self.status))

    @property
    def ok(self) -> bool:
        return self.status is RefStatus.OK

    @property
    def instance(self) -> InstanceId:
        """The instance of a per-instance reference (ValueError for a scene-level one)."""
        if self.item is None:
            raise ValueError(f"{self.kind} reference {self.path} belongs to no instance")
        return InstanceId(int(self.item))

    def cache_digest(self) -> dict[str, str]:
        """What of this reference a downstream cache key depends on: the content hash and the status."""
        return {"sha256": self.sha256, "status": self.status.value}

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "path": self.path,
            "sha256": self.sha256,
            "item": None if self.item is None else int(self.item),
            "status": self.status.value,
            "numbers": dict(self.numbers),
            "missing": None if self.missing is None else self.missing.to_json(),
            "detail": dict(self.detail),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Ref:
        return cls(
            kind=str(d["kind"]),
            path=str(d["path"]),
            sha256=str(d["sha256"]),
            item=None if d.get("item") is None else int(d["item"]),
            status=RefStatus(d.get("status", "ok")),
            numbers=dict(d.get("numbers", {})),
            missing=Missing.from_json(d["missing"]) if d.get("missing") else None,
            detail=dict(d.get("detail", {})),
        )
