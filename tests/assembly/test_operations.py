"""Typed operation records: the solver's log, their JSON form in layout.json, and reading them back."""

import json

import numpy as np
import pytest

from rescene_core.assembly import Operation, attach, operations_of
from rescene_core.assembly.scenes import bedroom
from rescene_core.config import AttachmentConfig


def test_json_form_keeps_key_order_and_rounds():
    op = Operation(
        3, "wall-aware", "floor snap", "rests-on -> floor", {"vertical_m": np.float64(0.1234567891234), "t": np.eye(2)}
    )
    d = op.to_json()
    assert list(d)[:4] == ["instance", "branch", "stage", "rule"]
    assert d["vertical_m"] == 0.123456789 and d["t"] == [[1.0, 0.0], [0.0, 1.0]]
    assert Operation.from_json(json.loads(json.dumps(d))) == op


def test_reserved_keys_rejected():
    with pytest.raises(ValueError, match="reserved"):
        Operation(1, "all", "input", "note", {"rule": "x"})


def test_layout_operations_read_back_as_records():
    objects, graph, shell = bedroom()
    layout = attach(objects, graph, shell, AttachmentConfig())
    ops = operations_of(json.loads(json.dumps(layout.to_json()))["operations"])
    assert ops and all(isinstance(o, Operation) for o in ops)
    assert ops == layout.operations and [o.to_json() for o in ops] == [o.to_json() for o in layout.operations]
    moves = [o for o in ops if "transform" in o.details]
    assert moves and all(np.asarray(o.details["transform"]).shape == (4, 4) for o in moves)
