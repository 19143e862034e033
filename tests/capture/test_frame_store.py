"""Frames kept on disk while a capture is built: the staging store, the writer taking its chunks over, masks
changed as they are read, and the instance fusion that spills points per instance."""

from __future__ import annotations

import dataclasses
import os
import socket
import subprocess
import sys

import numpy as np
import pytest
import zarr

from rescene_core.capture import depth_points
from rescene_core.capture.depth_points import instance_points
from rescene_core.capture.format import STORE_OWNER, FrameMap, FrameStore, write_capture
from tests.capture.toy import toy_capture_arrays


def _staged(arrays, tmp_path) -> FrameStore:
    t, h, w = arrays.instance_masks.shape
    store = FrameStore(t + 2, h, w, True, True, dir=tmp_path)  # two frames more, as if two were unreadable
    store.write(0, arrays.rgb[:2], arrays.depth[:2], arrays.instance_masks[:2])
    store.write(2, arrays.rgb[2:], arrays.depth[2:], arrays.instance_masks[2:])
    store.truncate(t)
    return store


def test_staged_frames_are_written_as_numpy_frames_and_linked(tmp_path):
    arrays = toy_capture_arrays(frames=5)
    store = _staged(arrays, tmp_path)
    assert len(store.rgb) == 5 and store.depth is not None and store.masks is not None
    from_numpy = write_capture(tmp_path / "a.zarr", arrays)
    staged = dataclasses.replace(arrays, rgb=store.rgb, depth=store.depth, instance_masks=store.masks)
    from_store = write_capture(tmp_path / "b.zarr", staged)
    a, b = zarr.open_group(str(from_numpy), mode="r"), zarr.open_group(str(from_store), mode="r")
    for name in ("rgb", "depth", "instance"):
        assert a[f"frames/{name}"].shape == b[f"frames/{name}"].shape
        assert np.array_equal(a[f"frames/{name}"][...], b[f"frames/{name}"][...]), name
    # the encoded chunks were taken over, not decoded and encoded again: the files are the store's
    chunk = from_store / "frames" / "rgb" / "c" / "4" / "0" / "0" / "0"
    assert os.stat(chunk).st_ino == os.stat(store.path / "rgb" / "c.4.0.0.0").st_ino
    assert not (store.path / "rgb" / "c.5.0.0.0").exists()  # the truncated tail is gone
    store.close()
    assert not store.path.exists()
    assert np.array_equal(b["frames/rgb"][...], arrays.rgb)  # the capture keeps its files


def test_frame_map_clears_ids_as_the_writer_reads(tmp_path):
    arrays = toy_capture_arrays(frames=3)
    store = _staged(arrays, tmp_path)
    assert store.masks is not None
    cleared = FrameMap(store.masks, lambda m: np.where(m == 2, 0, m).astype(np.int32), np.int32)
    assert cleared[1].shape == arrays.instance_masks.shape[1:]
    with pytest.raises(TypeError, match="by frame or by a slice"):
        cleared[[0, 2]]
    path = write_capture(tmp_path / "c.zarr", dataclasses.replace(arrays, instance_masks=cleared))
    written = np.asarray(zarr.open_group(str(path), mode="r")["frames/instance"][...])
    expected = np.where(arrays.instance_masks == 2, 0, arrays.instance_masks)
    assert (arrays.instance_masks == 2).any() and np.array_equal(written, expected)
    fresh = store.new_masks()  # masks made after reading (a mesh annotation's render) replace the read ones
    assert store.masks is fresh and fresh.shape == arrays.instance_masks.shape and not np.asarray(fresh).any()


def test_instance_points_spilled_every_frame_equal_one_spill(tmp_path, monkeypatch):
    arrays = toy_capture_arrays(frames=4, width=64, height=48)
    args = (arrays.depth, arrays.instance_masks, arrays.rgb, arrays.K, arrays.world_from_cam, {1})
    whole, stats_whole = instance_points(*args, spill_dir=tmp_path)
    monkeypatch.setattr(depth_points, "SPILL_FRAMES", 1)
    store = _staged(arrays, tmp_path)
    assert store.depth is not None and store.masks is not None
    spilled, stats_spilled = instance_points(
        store.depth, store.masks, store.rgb, arrays.K, arrays.world_from_cam, {1}, spill_dir=tmp_path
    )
    assert sorted(whole) == sorted(spilled) == [1, 2] and stats_whole == stats_spilled
    for iid in whole:
        assert np.array_equal(whole[iid][0], spilled[iid][0]) and np.array_equal(whole[iid][1], spilled[iid][1])
    store.close()
    assert list(tmp_path.iterdir()) == []  # the spill files and the staging store are gone


def test_streamed_thinning_has_open3d_voxels(tmp_path, monkeypatch):
    """A cloud above EXACT_POINTS is folded piece by piece on Open3D's grid: the same voxels, mean points and
    mean colours as ``voxel_down_sample`` of every point at once (only their order differs)."""
    import open3d as o3d

    rng = np.random.default_rng(0)
    pts = (rng.random((20000, 3)) * [2.0, 1.0, 0.5] + [-3.2, 0.7, 1.1]).astype(np.float32)
    cols = rng.integers(0, 256, (20000, 3), dtype=np.uint8)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts.astype(np.float64)))
    pcd.colors = o3d.utility.Vector3dVector(cols.astype(np.float64) / 255.0)
    ref = pcd.voxel_down_sample(0.05)
    monkeypatch.setattr(depth_points, "EXACT_POINTS", 1000)
    monkeypatch.setattr(depth_points, "FOLD_POINTS", 3000)
    spill = depth_points._Spill(tmp_path, colors=True)
    for a in range(0, len(pts), 700):
        spill.add(5, pts[a : a + 700], cols[a : a + 700])
        spill.flush()
    assert spill.count[5] == len(pts) and np.array_equal(spill.low[5], pts.min(axis=0))
    got = spill.thin(5, 0.05)
    assert list(tmp_path.iterdir()) == []

    def rows(cloud):
        both = np.hstack([np.asarray(cloud.points), np.asarray(cloud.colors)])
        return both[np.lexsort(both.T[::-1])]

    a, b = rows(ref), rows(got)
    assert a.shape == b.shape and len(a) > 1000
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)


def test_scene_points_streamed_keep_the_floor(tmp_path, monkeypatch):
    arrays = toy_capture_arrays(frames=4, width=64, height=48)
    whole = depth_points.scene_points(arrays.depth, arrays.K, arrays.world_from_cam, spill_dir=tmp_path)
    monkeypatch.setattr(depth_points, "EXACT_POINTS", 10)
    streamed = depth_points.scene_points(arrays.depth, arrays.K, arrays.world_from_cam, spill_dir=tmp_path)
    key = np.lexsort(whole.T[::-1])
    np.testing.assert_allclose(whole[key], streamed[np.lexsort(streamed.T[::-1])], rtol=0, atol=1e-9)


def test_a_store_left_by_a_killed_import_is_removed_by_the_next_one(tmp_path):
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    orphan = tmp_path / "rescene-frames-orphan"
    orphan.mkdir()
    (orphan / STORE_OWNER).write_text(f"{socket.gethostname()} {int(gone.stdout)}\n")
    live = tmp_path / "rescene-frames-live"
    live.mkdir()
    (live / STORE_OWNER).write_text(f"{socket.gethostname()} {os.getpid()}\n")
    elsewhere = tmp_path / "rescene-frames-elsewhere"
    elsewhere.mkdir()
    (elsewhere / STORE_OWNER).write_text(f"another-host {int(gone.stdout)}\n")
    store = FrameStore(2, 4, 4, False, False, dir=tmp_path)
    assert not orphan.exists() and live.exists() and elsewhere.exists() and store.path.exists()
