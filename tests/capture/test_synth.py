"""Synthetic captures: validity, determinism, ground truth, and the error dials (tiny preset)."""

from __future__ import annotations

import pytest

from rescene_core.capture import check_capture, open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.capture.synth import make_scene, synth_command, write_synth


@pytest.fixture(scope="module")
def tiny():
    return make_scene("tiny", seed=0)


def test_tiny_capture_is_valid_and_has_ground_truth(tmp_path):
    path = write_synth(tmp_path / "tiny.zarr", "tiny", seed=1)
    problems = check_capture(path)
    assert [p for p in problems if p.severity == "error"] == []
    capture = open_capture(path)
    assert capture.num_frames == 12 and capture.image_size == (160, 120)
    gt = read_ground_truth(capture)
    assert gt is not None and 1 <= len(gt.objects) <= 6
    labels = {i.label for i in capture.instances if i.structural}
    assert {"floor", "wall"} <= labels
    assert gt.graph_by_instance().check() == []


def test_write_refuses_existing_path(tmp_path):
    write_synth(tmp_path / "a.zarr", "tiny", seed=0)
    with pytest.raises(FileExistsError):
        write_synth(tmp_path / "a.zarr", "tiny", seed=0)


def test_unknown_preset_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown synth preset"):
        make_scene("huge", 0)


def test_synth_command_prints_and_returns_zero(tmp_path, capsys):
    assert synth_command(tmp_path / "c.zarr", preset="tiny", seed=2) == 0
    out = capsys.readouterr().out
    assert "wrote" in out and "objects" in out


def test_same_seed_same_arrays(tiny):
    again = make_scene("tiny", seed=0)
    a, b = tiny.arrays, again.arrays
    for name in ("rgb", "instance_masks", "depth", "K", "world_from_cam", "points", "colors", "point_ids"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), name
    assert a.instances == b.instances
    other = make_scene("tiny", seed=1)
    assert other.arrays.rgb.tobytes() != a.rgb.tobytes()
