"""`rescene bench synth` on the tiny preset: result shape, measured figures, table."""

from __future__ import annotations

from rescene_core.bench import synth


def test_synth_bench_measures_tiny(tmp_path):
    result = synth.run(seeds=[0], preset="tiny", work_dir=tmp_path)
    (row,) = result["runs"]
    assert row["preset"] == "tiny" and row["frames"] == 12
    assert row["seconds"] > 0 and row["seconds_per_frame"] > 0
    assert row["objects"] >= 1 and row["points"] > 0
    assert "tiny" in result["summary"] and "standard_seconds" not in result["aims"]
    text = synth.table(result)
    assert "tiny" in text and "s/frame" in text
    assert not list(tmp_path.glob("*.zarr"))
