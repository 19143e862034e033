"""``Operation``: one typed record per step of the attachment solver (a move, a skip, a note, a choice),
defined with the layout it belongs to (``rescene_core.records.layout``).

The solver logs an ``Operation`` for every rule it applies or skips; ``Layout.operations`` holds them and
``layout.json`` their JSON form, ``{"instance", "branch", "stage", "rule", **details}``, in that key order.
``operations_of`` reads JSON forms back as records.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from rescene_core.records.layout import HEAD, Operation, json_value

__all__ = ["HEAD", "Operation", "json_value", "operations_of"]


def operations_of(records: Iterable[Mapping[str, Any] | Operation]) -> tuple[Operation, ...]:
    """``Layout.operations`` (JSON form, e.g. read from ``layout.json``) as typed records."""
    return tuple(r if isinstance(r, Operation) else Operation.from_json(r) for r in records)
