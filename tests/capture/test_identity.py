"""Capture identity: the stamp written with the capture, the cheap check, copies and changes in place."""

import os
import shutil

import numpy as np
import pytest
import zarr

from rescene_core.capture.identity import IDENTITY_ATTR, CaptureChangedError, capture_identity, stamp_capture
from rescene_core.capture.synth import write_synth
from rescene_core.io import hash_tree


@pytest.fixture(scope="module")
def stamped(tmp_path_factory):
    return write_synth(tmp_path_factory.mktemp("identity") / "tiny.zarr", "tiny", seed=0)


def test_writer_stamps_and_cheap_check_reads_nothing(stamped):
    attrs = dict(zarr.open_group(str(stamped), mode="r").attrs)
    assert set(attrs[IDENTITY_ATTR]) == {"content_hash", "files", "stamped_at_ns"}
    assert "frames/rgb/zarr.json" in attrs[IDENTITY_ATTR]["files"]
    ident = capture_identity(stamped)
    assert ident.verification == "stamp"
    assert ident.rehashed_files == 0
    assert ident.content_hash == attrs[IDENTITY_ATTR]["content_hash"]
    full = capture_identity(stamped, full=True)
    assert full.content_hash == ident.content_hash
    assert full.rehashed_files == len(attrs[IDENTITY_ATTR]["files"])


def test_same_content_same_identity_wherever_it_lives(stamped, tmp_path):
    moved = shutil.copytree(stamped, tmp_path / "elsewhere.zarr")
    assert capture_identity(moved).content_hash == capture_identity(stamped).content_hash
    plain = tmp_path / "plain-copy.zarr"
    shutil.copytree(stamped, plain, copy_function=shutil.copy)  # new modification times: rehashed
    ident = capture_identity(plain)
    assert ident.content_hash == capture_identity(stamped).content_hash
    assert ident.rehashed_files > 0


def test_change_in_place_is_detected(stamped, tmp_path):
    copy = shutil.copytree(stamped, tmp_path / "changed.zarr")
    rgb = zarr.open_array(str(copy / "frames" / "rgb"), mode="r+")
    frame = np.asarray(rgb[0])
    rgb[0] = 255 - frame
    with pytest.raises(CaptureChangedError, match=r"files changed: frames/rgb/c/0"):
        capture_identity(copy)


def test_same_size_change_with_old_mtime_needs_full_check(stamped, tmp_path):
    copy = shutil.copytree(stamped, tmp_path / "sneaky.zarr")
    chunk = next(p for p in sorted((copy / "frames" / "rgb").rglob("*")) if p.is_file() and p.name != "zarr.json")
    st = chunk.stat()
    data = bytearray(chunk.read_bytes())
    data[-1] ^= 0xFF
    chunk.write_bytes(bytes(data))
    os.utime(chunk, ns=(st.st_atime_ns, st.st_mtime_ns))  # a change that hides its time
    capture_identity(copy)  # the cheap check trusts sizes and times
    with pytest.raises(CaptureChangedError, match="files changed"):
        capture_identity(copy, full=True)


def test_added_file_and_attribute_change_are_detected(stamped, tmp_path):
    copy = shutil.copytree(stamped, tmp_path / "added.zarr")
    (copy / "frames" / "stray.bin").write_bytes(b"x")
    with pytest.raises(CaptureChangedError, match="files added: frames/stray.bin"):
        capture_identity(copy)
    copy2 = shutil.copytree(stamped, tmp_path / "relabelled.zarr")
    group = zarr.open_group(str(copy2), mode="r+")
    group.attrs["scene_id"] = "another-room"
    with pytest.raises(CaptureChangedError, match="attributes changed"):
        capture_identity(copy2)
    stamp_capture(copy2)  # an intended change, restamped
    assert capture_identity(copy2).content_hash != capture_identity(stamped).content_hash


def test_unstamped_capture_is_hashed_whole(stamped, tmp_path):
    copy = shutil.copytree(stamped, tmp_path / "old.zarr")
    group = zarr.open_group(str(copy), mode="r+")
    del group.attrs[IDENTITY_ATTR]
    ident = capture_identity(copy)
    assert ident.verification == "unstamped"
    assert ident.content_hash == hash_tree(copy)
