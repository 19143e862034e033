"""Instance tasks through ``task.fn()``: view selection, asset generation, registration, and the
pass-through of Missing records."""

from __future__ import annotations

import json

import pytest

from rescene_core.config import AssetConfig, HierViewConfig, RegistrationConfig
from rescene_core.io import hash_file
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Missing, RefStatus, Stage
from rescene_core.stages import calls as stages
from tasks.dag import generate_asset, register_instance, select_views


def _views(run_dir, capture, ids=(2, 3, 4)):
    return select_views.fn(str(run_dir), capture, list(ids), HierViewConfig())


def test_views_write_one_file_and_one_reference_per_instance(fake_stages, capture, tmp_path):
    refs = _views(tmp_path, capture)
    run = RunPaths(tmp_path)
    assert [r.item for r in refs] == [2, 3, 4] and fake_stages["view"] == 1
    for r in refs:
        assert r.ok and r.kind == "view" and r.path == f"instances/{r.item}/view.json"
        assert r.sha256 == hash_file(run.view(r.item)) and r.numbers == {"frame": 0, "candidates": 1}
        assert json.loads(run.view(r.item).read_text())["view"]["frame"] == 0
    assert (tmp_path / "logs" / "segments" / "view.mcap").exists()


def test_an_instance_without_a_view_is_missing_and_passes_through(fake_stages, capture, tmp_path, monkeypatch):
    def views_without_3(cap, config, ids):
        return {i: Missing(InstanceId(i), "hierview", "seen in no frame") if i == 3 else v
                for i, v in fake_views(cap, config, ids).items()}  # fmt: skip

    fake_views = stages.select_views
    monkeypatch.setattr(stages, "select_views", views_without_3)
    view = _views(tmp_path, capture)[1]
    assert view.status is RefStatus.MISSING and view.missing.stage is Stage.VIEW
    assert json.loads(RunPaths(tmp_path).view(3).read_text())["missing"]["stage"] == "view"

    asset = generate_asset.fn(str(tmp_path), capture, view, AssetConfig())
    pose = register_instance.fn(str(tmp_path), capture, asset, RegistrationConfig())
    assert fake_stages["asset"] == 0 and fake_stages["registration"] == 0  # the library was never asked
    for ref, path in ((asset, RunPaths(tmp_path).asset_meta(3)), (pose, RunPaths(tmp_path).pose(3))):
        assert ref.missing == view.missing and json.loads(path.read_text())["status"] == "missing"


def test_asset_then_registration(fake_stages, capture, tmp_path):
    view = _views(tmp_path, capture)[0]
    asset = generate_asset.fn(str(tmp_path), capture, view, AssetConfig())
    run = RunPaths(tmp_path)
    assert asset.ok and asset.path == "instances/2/asset.json" and asset.numbers == {"vertices": 8, "faces": 12}
    meta = json.loads(run.asset_meta(2).read_text())
    assert meta["glb"] == "asset.glb" and meta["glb_sha256"] == hash_file(run.asset_glb(2))

    pose = register_instance.fn(str(tmp_path), capture, asset, RegistrationConfig(scale_max=1.0))
    assert pose.ok and pose.kind == "pose" and pose.item == 2
    assert pose.numbers["rmse"] == 0.01 and pose.numbers["inlier_ratio"] == 0.9
    assert pose.numbers["scale"] == pytest.approx(0.6, rel=0.05)  # the box's largest extent
    assert json.loads(run.pose(2).read_text())["pose"]["method"] == "fake"


def test_library_missing_from_registration_is_recorded(fake_stages, capture, tmp_path, monkeypatch):
    monkeypatch.setattr(
        stages, "register", lambda asset, target, config: Missing(asset.instance, "registration", "gates")
    )
    asset = generate_asset.fn(str(tmp_path), capture, _views(tmp_path, capture)[0], AssetConfig())
    pose = register_instance.fn(str(tmp_path), capture, asset, RegistrationConfig())
    assert pose.status is RefStatus.MISSING and pose.missing == Missing(InstanceId(2), Stage.REGISTRATION, "gates")


def test_an_injected_bad_input_fault_raises_before_the_library(fake_stages, capture, tmp_path):
    from rescene_core.stages.execution import BadInputError

    (tmp_path / "faults.json").write_text(json.dumps([{"stage": "asset", "item": 2, "kind": "bad_input"}]))
    view = _views(tmp_path, capture)[0]
    with pytest.raises(BadInputError, match="item 2"):
        generate_asset.fn(str(tmp_path), capture, view, AssetConfig())
    assert fake_stages["asset"] == 0
