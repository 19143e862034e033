"""A cache record whose output file is gone is dropped before Prefect looks it up: the task runs again
instead of returning a reference to nothing (an output deleted by hand, a run directory copied without it)."""

from __future__ import annotations

import json

from rescene_core.records import Ref, Stage
from tasks.common import RESULTS_DIR, StageInputs, drop_record_of_lost_output


def _record(run_dir, key: str, ref: Ref):
    """A cache record as Prefect's JSON serializer writes it: metadata, and the result as a JSON string."""
    path = run_dir / RESULTS_DIR / key
    path.parent.mkdir(parents=True, exist_ok=True)
    result = {"__class__": f"{Ref.__module__}.{Ref.__qualname__}", "data": {"kind": ref.kind, "path": ref.path}}
    path.write_text(json.dumps({"metadata": {"storage_key": str(path)}, "result": json.dumps(result)}))
    return path


def test_a_record_whose_file_is_gone_is_dropped_and_a_sound_one_kept(tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene/scene.json").write_text("{}")
    sound = _record(tmp_path, "export-sound", Ref("scene", "scene/scene.json", "0" * 64))
    lost = _record(tmp_path, "layout-lost", Ref("layout", "layout.json", "0" * 64))
    assert drop_record_of_lost_output(tmp_path, "export-sound") is None and sound.exists()
    assert drop_record_of_lost_output(tmp_path, "layout-lost") == tmp_path / "layout.json"
    assert not lost.exists()
    assert drop_record_of_lost_output(tmp_path, "no-such-record") is None


def test_the_cache_policy_checks_the_record_under_the_key_it_computes(tmp_path):
    policy = StageInputs(stage=Stage.SHELL)
    key = policy.compute_key(None, {"run_dir": str(tmp_path)}, {})  # type: ignore[arg-type]
    record = _record(tmp_path, key, Ref("shell", "shell.json", "0" * 64))
    assert policy.compute_key(None, {"run_dir": str(tmp_path)}, {}) == key  # type: ignore[arg-type]
    assert not record.exists()  # shell.json is not there: the stage runs again
    (tmp_path / "shell.json").write_text("{}")
    record = _record(tmp_path, key, Ref("shell", "shell.json", "0" * 64))
    policy.compute_key(None, {"run_dir": str(tmp_path)}, {})  # type: ignore[arg-type]
    assert record.exists()
