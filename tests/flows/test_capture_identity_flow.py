"""The flow's capture identity (the stamp, checked cheaply or in full, recorded in the manifest) and cache
keys free of the run directory's location."""

from __future__ import annotations

import json
import shutil

import pytest

from rescene_core.capture import CaptureError
from rescene_core.capture.identity import CaptureChangedError
from rescene_core.config import RunConfig
from rescene_core.records import Ref, Stage
from rescene_core.stages.execution import capture_ref
from tasks.common import StageInputs


def test_capture_ref_stamp_and_full(box_capture_path):
    cheap = capture_ref(box_capture_path)
    full = capture_ref(box_capture_path, "full")
    assert cheap.sha256 == full.sha256
    assert cheap.detail["verification"] == "stamp" and cheap.detail["rehashed_files"] == 0
    assert full.detail["verification"] == "full" and full.detail["rehashed_files"] > 0
    with pytest.raises(ValueError, match="verify_capture='fast'"):
        capture_ref(box_capture_path, "fast")


def test_capture_ref_detects_change_in_place(box_capture_path, tmp_path):
    copy = shutil.copytree(box_capture_path, tmp_path / "copy.zarr")
    assert capture_ref(copy).sha256 == capture_ref(box_capture_path).sha256  # a copy keeps its identity
    import zarr

    depth = zarr.open_group(str(copy), mode="r+")["frames/depth"]
    depth[0] = depth[0] + 0.5  # a valid capture with other data, rewritten in place
    with pytest.raises(CaptureChangedError, match="files changed"):
        capture_ref(copy)


def test_cache_key_leaves_out_run_dir():
    policy = StageInputs(stage=Stage.SHELL)
    capture = Ref(kind="capture", path="/data/a.zarr", sha256="ab" * 32)
    inputs = {"capture": capture, "config": RunConfig().shell}
    key_a = policy.compute_key(None, {"run_dir": "/runs/a", **inputs}, {})
    key_b = policy.compute_key(None, {"run_dir": "/elsewhere/b", **inputs}, {})
    assert key_a == key_b
    moved = Ref(kind="capture", path="/mnt/other/a.zarr", sha256="ab" * 32)  # the capture's path is not in it either
    assert policy.compute_key(None, {"run_dir": "/runs/a", **inputs, "capture": moved}, {}) == key_a
    changed = Ref(kind="capture", path="/data/a.zarr", sha256="cd" * 32)
    assert policy.compute_key(None, {"run_dir": "/runs/a", **inputs, "capture": changed}, {}) != key_a


def test_moved_run_dir_keeps_its_cache(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import run_flow

    first = tmp_path / "first"
    assert run_flow(box_capture_path, first, RunConfig()).is_completed()
    manifest = json.loads((first / "manifest.json").read_text())
    assert manifest["capture"]["verification"] == "stamp"
    assert manifest["capture"]["sha256"] == capture_ref(box_capture_path).sha256
    moved = tmp_path / "moved" / "run"
    moved.parent.mkdir()
    shutil.move(first, moved)
    fake_stages.clear()
    state = run_flow(box_capture_path, moved, RunConfig(), verify_capture="full")
    assert state.is_completed(), state.message
    assert sum(fake_stages.values()) == 0, dict(fake_stages)
    manifest = json.loads((moved / "manifest.json").read_text())
    assert manifest["capture"]["verification"] == "full" and manifest["capture"]["rehashed_files"] > 0
    assert manifest["stages"]["registration"] == {"cached": 3}


def test_flow_fails_on_capture_changed_in_place(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import run_flow

    copy = shutil.copytree(box_capture_path, tmp_path / "copy.zarr")
    import zarr

    rgb = zarr.open_group(str(copy), mode="r+")["frames/rgb"]
    rgb[0] = 255 - rgb[0]
    state = run_flow(copy, tmp_path / "run", RunConfig())
    assert state.is_failed()
    assert "CaptureChangedError" in state.message and "the capture changed since it was written" in state.message
    assert fake_stages.get("shell", 0) == 0


def test_flow_fails_on_a_chunk_that_no_longer_decodes(prefect_server, fake_stages, box_capture_path, tmp_path):
    """Garbage in a chunk with its size and modification time unchanged passes the cheap stamp check;
    the validation stage decodes every chunk and fails the run before any stage, naming array and frame."""
    import os

    from flows.scene import run_flow

    copy = shutil.copytree(box_capture_path, tmp_path / "copy.zarr")
    chunk = copy / "frames/rgb/c/1/0/0/0"
    before = chunk.stat()
    chunk.write_bytes(os.urandom(before.st_size))
    os.utime(chunk, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert capture_ref(copy).sha256 == capture_ref(box_capture_path).sha256  # the cheap check cannot tell
    state = run_flow(copy, tmp_path / "run", RunConfig())
    assert state.is_failed()
    assert "CaptureError" in state.message and "frames/rgb: frame 1 cannot be decoded" in state.message
    assert fake_stages.get("shell", 0) == 0
    # rehashing every file (--verify-capture full) finds the change before any task, and the capture's
    # problems are the clearer error
    with pytest.raises(CaptureError, match="frames/rgb: frame 1 cannot be decoded"):
        capture_ref(copy, "full")
