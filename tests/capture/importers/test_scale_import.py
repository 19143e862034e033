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
    assert 0.05 < got["peak_rss_gb"] < 6.0 and got["cpu_seconds"] > 0
    assert (tmp_path / "imported.zarr").is_dir()
    row = {"seed": 0, "frames": got["frames"], "objects": 5, "image_size": [160, 120], "import": got}
    row |= {"load_import": 1.0, "load_after": 1.0}
    summary = scale._summary([row])
    assert summary["aims_met"]["at_most_linear"] is None  # one frame count: no slope
    assert summary["aims_met"]["run_seconds_at_600"] is None and summary["slopes"]["import total"] is None
    text = scale.table({"preset": "tiny", "seeds": [0], "frames": [got["frames"]], "rows": [row], **summary})
    assert "import" in text and "frames/s" in text and "not measured" in text


def test_an_opened_capture_is_written_as_from_memory(tmp_path, tiny_scene):
    from rescene_core.capture import open_capture
    from rescene_core.capture.format import write_capture

    path = write_capture(tmp_path / "tiny.zarr", tiny_scene.arrays)
    from_memory = write_scannet(tiny_scene.arrays, tmp_path / "a", threads=1)
    from_disk = write_scannet(open_capture(path, validate=False), tmp_path / "b", threads=2)
    files = sorted(p.relative_to(from_memory) for p in from_memory.rglob("*") if p.is_file())
    assert files and files == sorted(p.relative_to(from_disk) for p in from_disk.rglob("*") if p.is_file())
    assert all((from_memory / f).read_bytes() == (from_disk / f).read_bytes() for f in files)
