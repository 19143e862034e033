"""References, cache-key digests and fault injection (tasks/common.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from prefect.serializers import JSONSerializer

from rescene_core.config import RegistrationConfig
from rescene_core.io import hash_file
from rescene_core.records import InstanceId, Missing, Ref, RefStatus, Stage
from rescene_core.stages.execution import BadInputError, TransientStageError, inject_fault, make_ref
from tasks.common import StageInputs, digest, is_transient


def test_make_ref_names_the_file_by_its_run_relative_path_and_hash(tmp_path):
    path = tmp_path / "instances" / "3" / "pose.json"
    path.parent.mkdir(parents=True)
    path.write_text("{}")
    ref = make_ref(tmp_path, path, "pose", 3, numbers={"scale": 1.5})
    assert ref.path == "instances/3/pose.json" and ref.sha256 == hash_file(path)
    assert ref.ok and ref.item == 3 and ref.missing is None
    gone = make_ref(tmp_path, "instances/3/pose.json", "pose", 3, missing=Missing(InstanceId(3), "registration", "x"))
    assert gone.status is RefStatus.MISSING and gone.missing.stage is Stage.REGISTRATION


def test_ref_round_trips_through_prefects_json_serializer():
    """Task results are persisted with result_serializer="json": the Ref comes back equal, typed, no pickle."""
    ref = Ref("pose", "instances/3/pose.json", "ab" * 32, 3, RefStatus.MISSING, {"faces": 12},
              Missing(InstanceId(3), Stage.ASSET, "no mesh"), {"frames": [1, 2]})  # fmt: skip
    blob = JSONSerializer().dumps(ref)
    assert b"pickle" not in blob and json.loads(blob)["data"]["status"] == "missing"
    back = JSONSerializer().loads(blob)
    assert back == ref and isinstance(back.numbers["faces"], int) and back.missing.stage is Stage.ASSET
    assert Ref.from_json(ref.to_json()) == ref


def test_digest_keeps_only_content_hashes_and_config_hashes():
    ref = Ref("pose", "instances/3/pose.json", "ab" * 32, 3, numbers={"rmse": 0.1})
    moved = Ref("pose", "elsewhere.json", "ab" * 32, 3, numbers={"rmse": 0.2})
    assert digest(ref) == digest(moved) == {"sha256": "ab" * 32, "status": "ok"}
    assert digest([ref]) != digest([Ref("pose", "instances/3/pose.json", "cd" * 32, 3)])
    a, b = RegistrationConfig(), RegistrationConfig(scale_max=1.2)
    assert digest(a) != digest(b) and digest(a) == digest(RegistrationConfig())
    assert digest([Missing(InstanceId(2), "view", "x")]) == [{"instance": 2, "stage": "view", "reason": "x"}]
    with pytest.raises(TypeError, match="pass a reference"):
        digest(np.zeros(3))


def test_cache_key_changes_with_the_input_hash_not_with_the_path():
    policy = StageInputs(stage=Stage.REGISTRATION)
    ref = Ref("asset", "instances/3/asset.json", "ab" * 32, 3)
    key = policy.compute_key(None, {"asset": ref, "config": RegistrationConfig()}, {})
    same = policy.compute_key(None, {"asset": Ref("asset", "x", "ab" * 32, 3), "config": RegistrationConfig()}, {})
    other = policy.compute_key(None, {"asset": Ref("asset", "x", "cd" * 32, 3), "config": RegistrationConfig()}, {})
    assert key == same != other and key.startswith("registration-")


def test_faults_fire_the_given_number_of_times(tmp_path):
    (tmp_path / "faults.json").write_text(
        json.dumps(
            [
                {"stage": "asset", "item": 3, "kind": "bad_input", "times": 1},
                {"stage": "relations", "item": 0, "kind": "transient", "times": 2},
            ]
        )  # fmt: skip
    )
    with pytest.raises(BadInputError):
        inject_fault(tmp_path, Stage.ASSET, 3)
    inject_fault(tmp_path, Stage.ASSET, 3)  # fired once: cleared
    inject_fault(tmp_path, Stage.ASSET, 4)  # another item: no fault
    for _ in range(2):
        with pytest.raises(TransientStageError):
            inject_fault(tmp_path, Stage.RELATIONS, 0)
    inject_fault(tmp_path, Stage.RELATIONS, 0)
    assert (tmp_path / ".faults" / "relations-000000.count").read_text().strip() == "2"


def test_only_transient_errors_are_retried():
    assert is_transient(TimeoutError()) and is_transient(TransientStageError("x"))
    assert not is_transient(BadInputError("x")) and not is_transient(KeyError("x"))
