"""The validator reports every problem, names the array and the fix, and never raises a traceback."""

import shutil
from dataclasses import replace

import numpy as np
import pytest
import zarr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flows.cli import main
from rescene_core.capture import CaptureError, check_capture, open_capture, write_capture
from tests.capture.toy import toy_capture_arrays


def errors(path):
    return [p for p in check_capture(path) if p.severity == "error"]


def test_valid_capture_has_no_errors(tmp_path):
    path = write_capture(tmp_path / "ok.zarr", toy_capture_arrays())
    assert errors(path) == []


def test_reports_every_problem_at_once(tmp_path):
    arrays = toy_capture_arrays()
    K = arrays.K.copy()
    K[0, 0, 1] = 5.0  # skew: not pinhole
    poses = arrays.world_from_cam.copy()
    poses[1, :3, :3] *= 2.0  # scaled: not a rotation
    masks = arrays.instance_masks.copy()
    masks[0, 0, 0] = 77  # an id the table lacks
    pts = arrays.points.copy()
    pts[3] = np.nan
    bad = replace(arrays, K=K, world_from_cam=poses, instance_masks=masks, points=pts)
    path = write_capture(tmp_path / "bad.zarr", bad)
    found = {(p.where, p.message.split(" ")[0]) for p in errors(path)}
    wheres = {w for w, _ in found}
    assert {"frames/K", "frames/world_from_cam", "frames/instance", "instances/points"} <= wheres
    assert all(p.fix for p in errors(path))


def test_frame_count_mismatch_and_dtype(tmp_path):
    arrays = toy_capture_arrays()
    path = write_capture(tmp_path / "c.zarr", replace(arrays, K=arrays.K[:1], depth=arrays.depth.astype(np.float64)))
    msgs = [str(p) for p in errors(path)]
    assert any("frames/K" in m and "frames" in m for m in msgs)
    assert any("frames/depth" in m and "float32" in m for m in msgs)


def test_offsets_and_empty_clouds(tmp_path):
    arrays = toy_capture_arrays()
    offsets = arrays.point_offsets.copy()
    offsets[1] = 0  # instance 1 empty
    path = write_capture(tmp_path / "c.zarr", replace(arrays, point_offsets=offsets))
    assert any("empty point clouds" in p.message for p in errors(path))
    offsets = arrays.point_offsets.copy()
    offsets[-1] += 5
    path = write_capture(tmp_path / "d.zarr", replace(arrays, point_offsets=offsets))
    assert any("ends at" in p.message for p in errors(path))


def test_missing_arrays_and_attrs(tmp_path):
    path = write_capture(tmp_path / "c.zarr", toy_capture_arrays())
    shutil.rmtree(path / "frames" / "rgb")
    root = zarr.open_group(str(path), mode="r+")
    root.attrs["units"] = "mm"
    del root.attrs["scene_id"]
    where = {p.where for p in errors(path)}
    assert {"frames/rgb", "attrs.units", "attrs.scene_id"} <= where


def test_table_ids_not_in_masks_warn(tmp_path):
    arrays = toy_capture_arrays()
    masks = arrays.instance_masks.copy()
    masks[masks == 2] = 0
    path = write_capture(tmp_path / "c.zarr", replace(arrays, instance_masks=masks))
    warnings = [p for p in check_capture(path) if p.severity == "warning"]
    assert any("appear in no mask" in p.message for p in warnings)
    open_capture(path)  # warnings do not stop loading


def test_cli_exit_codes(tmp_path, capsys):
    good = write_capture(tmp_path / "good.zarr", toy_capture_arrays())
    assert main(["validate", str(good)]) == 0
    assert "valid capture" in capsys.readouterr().out
    arrays = toy_capture_arrays()
    K = arrays.K.copy()
    K[:, 2, 2] = 2.0
    bad = write_capture(tmp_path / "bad.zarr", replace(arrays, K=K))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "frames/K" in err and "INVALID" in err
    assert main(["validate", str(tmp_path / "nothing.zarr")]) == 2


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    return write_capture(tmp_path_factory.mktemp("pristine") / "p.zarr", toy_capture_arrays())


ARRAYS = [
    "frames/rgb",
    "frames/K",
    "frames/world_from_cam",
    "frames/instance",
    "frames/depth",
    "instances/ids",
    "instances/offsets",
    "instances/points",
    "instances/colors",
]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    target=st.sampled_from(ARRAYS),
    action=st.sampled_from(["delete", "nan", "scale", "truncate", "retype", "garbage_chunk", "attr"]),
    index=st.integers(min_value=0, max_value=10_000),
    value=st.floats(allow_nan=True, allow_infinity=True, width=32),
)
def test_random_corruption_loads_or_raises_capture_error(pristine, tmp_path_factory, target, action, index, value):
    path = tmp_path_factory.mktemp("corrupt") / "c.zarr"
    shutil.copytree(pristine, path)
    root = zarr.open_group(str(path), mode="r+")
    group_name, name = target.split("/")
    group = root[group_name]
    data = np.asarray(group[name][...])
    if action == "delete":
        del group[name]
    elif action == "attr":
        root.attrs["instances"] = [{"id": index % 5, "label": "", "structural": "no"}] if index % 2 else "oops"
    elif action == "garbage_chunk":
        chunks = [p for p in (path / group_name / name).rglob("*") if p.is_file() and p.name != "zarr.json"]
        if chunks:
            chunks[index % len(chunks)].write_bytes(b"\x00garbage")
    else:
        if action == "nan" and data.dtype.kind == "f":
            flat = data.reshape(-1)
            flat[index % flat.size] = value
        elif action == "scale":
            data = (data * (1 + index % 3)).astype(data.dtype)
        elif action == "truncate":
            data = data[: max(0, data.shape[0] - 1 - index % 2)]
        elif action == "retype":
            data = data.astype(np.float64 if data.dtype != np.float64 else np.float32)
        del group[name]
        group.create_array(name, data=data)
    try:
        cap = open_capture(path)
    except CaptureError as err:
        assert err.problems
        assert str(path) in str(err)
    else:
        cap.summary()


def _overwrite_with_garbage(chunk):
    """Bytes that no longer decode, of the chunk's own size (as a disk or copy fault leaves them)."""
    chunk.write_bytes(np.random.default_rng(0).bytes(chunk.stat().st_size))


def test_undecodable_chunks_named_by_array_and_frame(tmp_path, capsys):
    path = write_capture(tmp_path / "c.zarr", toy_capture_arrays(frames=3))
    assert errors(path) == []
    _overwrite_with_garbage(path / "frames/rgb/c/1/0/0/0")
    _overwrite_with_garbage(path / "frames/instance/c/2/0/0")
    _overwrite_with_garbage(path / "instances/points/c/0/0")
    found = {p.where: p.message for p in errors(path)}
    assert set(found) == {"frames/rgb", "frames/instance", "instances/points"}, found
    assert found["frames/rgb"].startswith("frame 1 cannot be decoded") and "frames/rgb/c/1/0/0/0" in found["frames/rgb"]
    assert found["frames/instance"].startswith("frame 2 cannot be decoded")
    n = zarr.open_group(str(path), mode="r")["instances/points"].shape[0]
    assert found["instances/points"].startswith(f"rows 0-{n - 1} cannot be decoded")
    with pytest.raises(CaptureError, match="frame 1 cannot be decoded"):
        open_capture(path)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "frames/rgb: frame 1 cannot be decoded" in err and "frames/instance: frame 2 cannot be decoded" in err


def test_changed_bytes_that_still_decode_are_found_against_the_stamp(tmp_path, capsys):
    """Four bytes flipped inside a chunk, its size and modification time unchanged (as a silent disk fault
    leaves it): the chunk still decodes, to other pixels; the cheap stamp check trusts the time, rehashing
    every file (--full) finds it."""
    import os

    path = write_capture(tmp_path / "c.zarr", toy_capture_arrays())
    chunk = path / "frames/rgb/c/0/0/0/0"
    before = chunk.stat()
    data = bytearray(chunk.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 4] = bytes(b ^ 0xFF for b in data[middle : middle + 4])
    chunk.write_bytes(bytes(data))
    os.utime(chunk, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert errors(path) == []  # it decodes: only the stamp can tell
    assert main(["validate", str(path)]) == 0
    capsys.readouterr()
    assert main(["validate", str(path), "--full"]) == 2
    err = capsys.readouterr().err
    assert "attrs.identity: the capture changed since it was written (files changed: frames/rgb/c/0/0/0/0)" in err
