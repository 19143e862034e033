"""The scale suite's import child (rescene_core/bench/scale.py) on a tiny ScanNet export: it imports and
reports its seconds, its steps and its peak resident set."""

from __future__ import annotations

from rescene_core.bench import scale
from rescene_core.capture.importers.layouts import write_scannet


def test_the_import_child_reports_seconds_steps_and_rss(tmp_path, tiny_scene):
    scan = write_scannet(tiny_scene.arrays, tmp_path / "scan", threads=1)
    result = tmp_path / "import.json"
    scale.child_import(scan, tmp_path / "imported.zarr", result)
    got = scale.read_json(result)
    assert got["frames"] == tiny_scene.arrays.rgb.shape[0] and got["fps"] > 0 and got["seconds"] > 0
    assert set(got["steps"]) >= {"read", "align", "points", "write"}
    assert all(v["seconds"] >= 0 for v in got["steps"].values())
    assert 0.05 < got["peak_rss_gb"] < 6.0
    assert (tmp_path / "imported.zarr").is_dir()
