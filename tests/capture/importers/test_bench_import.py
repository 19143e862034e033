"""The `import` benchmark suite on the tiny preset (the real sample left out to keep it short)."""

from __future__ import annotations

import json

import pytest

from rescene_core.bench import SUITES, run_suite


@pytest.mark.slow
def test_import_suite_measures_round_trips_gravity_and_segmentation(tmp_path, monkeypatch):
    from rescene_core.bench import importers

    assert SUITES["import"] == "rescene_core.bench.importers"
    monkeypatch.setattr(importers, "REAL_SAMPLE", tmp_path / "absent")
    run_suite("import", out_dir=tmp_path, seeds=[0], preset="tiny")
    result = json.loads((tmp_path / "import.json").read_text())
    seed = result["per_seed"][0]
    assert set(seed["round_trip"]) == {"panoptic", "scannet", "nerfstudio"}
    assert result["summary"]["round_trip_exact"] is True
    assert seed["gravity"]["floor_normal_error_deg"] < 1.0
    for mode in ("geometric", "masks"):
        seg = seed["segmentation"][mode]
        assert 0.0 <= seg["recall_large"] <= 1.0 and seg["seconds"] > 0
        assert 0 <= seg["touching_pairs_apart"] <= seg["touching_pairs"]
        assert len(seg["touching_pairs_merged"]) == seg["touching_pairs"] - seg["touching_pairs_apart"]
    assert result["summary"]["development"]["masks"]["recall_large"] == seed["segmentation"]["masks"]["recall_large"]
    assert "skipped" in result["real_sample"]
    text = importers.table(result)
    assert "segmentation: set | seed | mode" in text and "development masks" in text and "no real sample" in text
