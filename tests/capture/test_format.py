import json

import numpy as np
import pytest

from rescene_core.capture import CaptureError, check_capture, open_capture, write_capture
from rescene_core.records import Instance
from tests.capture.toy import toy_capture_arrays


def test_round_trip(tmp_path):
    arrays = toy_capture_arrays()
    path = write_capture(tmp_path / "toy.zarr", arrays)
    cap = open_capture(path)
    assert cap.scene_id == "toy"
    assert cap.instances == arrays.instances
    np.testing.assert_array_equal(cap.rgb[...], arrays.rgb)
    np.testing.assert_array_equal(cap.instance_masks[...], arrays.instance_masks)
    np.testing.assert_array_equal(cap.depth[...], arrays.depth)
    np.testing.assert_array_equal(cap.K, arrays.K)
    np.testing.assert_array_equal(cap.world_from_cam, arrays.world_from_cam)
    pc = cap.point_cloud(2)
    start, end = arrays.point_offsets[1:3]  # instance 2 is the second in the CSR order
    assert end > start
    np.testing.assert_array_equal(pc.points, arrays.points[start:end])
    assert len(cap.point_cloud(99)) == 0
    assert cap.camera(1).center[0] == pytest.approx(0.1)
    assert cap.summary()["objects"] == 1
    assert cap.object_instances == (Instance(2, "chair"),)


def test_write_is_atomic_and_refuses_overwrite(tmp_path):
    path = write_capture(tmp_path / "toy.zarr", toy_capture_arrays())
    with pytest.raises(FileExistsError):
        write_capture(path, toy_capture_arrays())

    def boom(root):
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        write_capture(tmp_path / "other.zarr", toy_capture_arrays(), extra=boom)
    assert not (tmp_path / "other.zarr").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["toy.zarr"]


def test_camera_projection_round_trip(tmp_path):
    cap = open_capture(write_capture(tmp_path / "toy.zarr", toy_capture_arrays()))
    cam = cap.camera(1)
    uv, z = cam.project(np.array([[0.1, 0.0, 2.0]]))
    np.testing.assert_allclose(uv[0], [16.0, 12.0])
    assert z[0] == pytest.approx(2.0)


def test_not_a_group(tmp_path):
    (tmp_path / "x.zarr").write_text("hello")
    problems = check_capture(tmp_path / "x.zarr")
    assert problems and "not a Zarr group" in problems[0].message
    assert check_capture(tmp_path / "missing.zarr")[0].message == "does not exist"
    with pytest.raises(CaptureError):
        open_capture(tmp_path / "missing.zarr")


def _rewrite_attrs(path, **changes):
    meta = json.loads((path / "zarr.json").read_text())
    meta["attributes"].update(changes)
    (path / "zarr.json").write_text(json.dumps(meta))
