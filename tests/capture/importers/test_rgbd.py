"""The RGB-D folder importer and gravity alignment: round trip, a y-up recorder, the real sample's
alignment, and bad input (clear errors naming the file, dropped frames counted, nothing half written)."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pytest
from PIL import Image

from flows.cli import main
from rescene_core.capture import open_capture
from rescene_core.capture.align import AlignConfig, camera_up, estimate_alignment
from rescene_core.capture.depth_points import scene_points
from rescene_core.capture.importers import ImportInputError, ImportOptions, import_capture, report_path
from rescene_core.capture.importers.common import read_depth
from rescene_core.capture.importers.layouts import Y_UP_FROM_Z_UP, write_panoptic, write_rgbd
from rescene_core.capture.importers.rgbd import read_rgbd
from rescene_core.records import Instance, InstanceId


def test_panoptic_round_trip_keeps_poses_intrinsics_masks_depth(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    src = write_panoptic(a, tmp_path / "src")
    report = import_capture("panoptic", src, tmp_path / "out.zarr", ImportOptions(align="none"))
    cap = open_capture(tmp_path / "out.zarr")
    np.testing.assert_allclose(cap.world_from_cam, a.world_from_cam, atol=1e-9)
    np.testing.assert_allclose(cap.K, a.K, atol=1e-9)
    np.testing.assert_array_equal(np.asarray(cap.instance_masks[...]), a.instance_masks)
    np.testing.assert_allclose(np.asarray(cap.depth[...]), a.depth, atol=5e-4)
    assert {(int(i.id), i.label, i.structural) for i in cap.instances} <= {
        (int(i.id), i.label, i.structural) for i in a.instances
    }
    assert report["frames"]["kept"] == len(a.rgb) and report["frames"]["dropped"] == 0
    assert cap.source == "panoptic-masks" and report["segmenter"] == "panoptic-masks"
    assert json.loads(report_path(tmp_path / "out.zarr").read_text())["frames"]["kept"] == len(a.rgb)


def test_an_object_mask_too_small_for_depth_points_is_dropped_and_reported(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    masks = a.instance_masks.copy()
    masks[0, 10:14, 10:14] = 99  # 16 pixels: nothing survives the 2 px erosion
    arrays = dataclasses.replace(
        a, instance_masks=masks, instances=(*a.instances, Instance(InstanceId(99), "speck", False))
    )
    src = write_panoptic(arrays, tmp_path / "src")
    report = import_capture("panoptic", src, tmp_path / "out.zarr", ImportOptions(align="none"))
    cap = open_capture(tmp_path / "out.zarr")
    assert 99 not in {int(i.id) for i in cap.instances} and not (np.asarray(cap.instance_masks[...]) == 99).any()
    assert all(len(cap.point_cloud(i.id)) for i in cap.object_instances)
    inst = report["instances"]
    assert inst["dropped"] == 1 and inst["dropped_by_reason"] == {"no depth points": 1}
    (dropped,) = inst["dropped_instances"]
    assert dropped["id"] == 99 and dropped["label"] == "speck" and dropped["mask_pixels"] == 16
    assert any("dropped, no depth points" in n for n in report["notes"])


def test_y_up_recorder_is_aligned_to_z_up_with_the_floor_at_zero(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    src = write_panoptic(a, tmp_path / "src", source_from_world=Y_UP_FROM_Z_UP)
    import_capture("panoptic", src, tmp_path / "out.zarr", ImportOptions(), align_config=AlignConfig(yaw=False))
    cap = open_capture(tmp_path / "out.zarr")
    al = cap.attrs["alignment"]
    assert al["method"] == "floor"
    # the floor normal found in the y-up source is +y
    assert np.degrees(np.arccos(np.clip(np.asarray(al["floor_normal_source"]) @ [0, 1, 0], -1, 1))) < 1.0
    # camera heights above the floor and camera up directions come back (the synthetic floor is z = 0)
    np.testing.assert_allclose(cap.world_from_cam[:, 2, 3], a.world_from_cam[:, 2, 3], atol=0.02)
    np.testing.assert_allclose(cap.world_from_cam[:, 2, :3], a.world_from_cam[:, 2, :3], atol=0.02)
    # the stored transform maps the aligned poses back to the source's
    back = np.einsum("ij,tjk->tik", np.asarray(al["source_from_aligned"]), cap.world_from_cam)
    np.testing.assert_allclose(back, np.einsum("ij,tjk->tik", Y_UP_FROM_Z_UP, a.world_from_cam), atol=1e-6)


@pytest.mark.slow
def test_real_sample_floor_matches_the_cameras_up(hololens):
    frames = read_rgbd(hololens, ImportOptions())  # all 75 frames: the mean up of a subset wanders
    fused = scene_points(frames.depth, frames.K, frames.world_from_cam)
    al = estimate_alignment(fused, frames.world_from_cam)
    assert al.method == "floor"
    assert al.camera_up_angle_deg < 2.0
    assert np.abs(camera_up(frames.world_from_cam) @ [0, 1, 0]) > 0.99  # a y-up recorder
    # floor points sit at z = 0 within 2 cm after alignment
    pts = fused @ al.aligned_from_source[:3, :3].T + al.aligned_from_source[:3, 3]
    floor = pts[np.abs(pts[:, 2]) < 0.05]
    assert len(floor) > 500 and abs(float(np.median(floor[:, 2]))) < 0.02


def _copy_rgbd(tiny_scene, tmp_path):
    return write_rgbd(tiny_scene.arrays, tmp_path / "src")


def test_missing_and_extra_files_name_the_file(tiny_scene, tmp_path):
    src = _copy_rgbd(tiny_scene, tmp_path)
    (src / "depth" / "00003.png").unlink()
    with pytest.raises(ImportInputError, match=r"00003\.png"):
        read_rgbd(src, ImportOptions())
    shutil.copy(src / "depth" / "00004.png", src / "depth" / "00003.png")
    shutil.copy(src / "depth" / "00004.png", src / "depth" / "00099.png")
    with pytest.raises(ImportInputError, match=r"00099\.png"):
        read_rgbd(src, ImportOptions())
    (src / "depth" / "00099.png").unlink()
    (src / "K.txt").unlink()
    with pytest.raises(ImportInputError, match=r"K\.txt"):
        read_rgbd(src, ImportOptions())


def test_frame_count_mismatch_and_depth_unit(tiny_scene, tmp_path):
    src = _copy_rgbd(tiny_scene, tmp_path)
    lines = (src / "poses.txt").read_text().splitlines()
    (src / "poses.txt").write_text("\n".join(lines[:-1]) + "\n")
    with pytest.raises(ImportInputError, match=r"poses\.txt: has 11 poses for 12 images"):
        read_rgbd(src, ImportOptions())
    (src / "poses.txt").write_text("\n".join(lines) + "\n")
    with pytest.raises(ImportInputError, match=r"median depth is .* m with --depth-scale 1,.*--depth-scale 0\.001\)"):
        read_rgbd(src, ImportOptions(depth_scale=1.0, max_depth=1e9))


def test_bad_poses_and_unreadable_images_are_dropped_and_counted(tiny_scene, tmp_path):
    src = _copy_rgbd(tiny_scene, tmp_path)
    poses = np.loadtxt(src / "poses.txt")
    poses[2] = np.nan
    poses[5, :3] *= 2.0  # scaled: not rigid
    np.savetxt(src / "poses.txt", poses, fmt="%.17g")
    (src / "images" / "00007.png").write_bytes(b"not a png")
    frames = read_rgbd(src, ImportOptions())
    reasons = {d.frame: d.reason for d in frames.dropped}
    assert set(reasons) == {2, 5, 7}
    assert "NaN" in reasons[2] and "not rigid" in reasons[5] and "unreadable" in reasons[7]
    assert len(frames.names) == 9 and "00007" not in frames.names


def test_failed_import_leaves_nothing_and_cli_says_why(tiny_scene, tmp_path, capsys):
    src = _copy_rgbd(tiny_scene, tmp_path)
    out = tmp_path / "out.zarr"
    # no masks and no --segment: a clear error, nothing written
    code = main(["import", "rgbd", str(src), str(out), "--align", "none"])
    err = capsys.readouterr().err
    assert code == 2 and "no instance masks" in err and "--segment geometric" in err
    assert not out.exists() and not report_path(out).exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.zarr")]
    code = main(["import", "rgbd", str(tmp_path / "nowhere"), str(out)])
    assert code == 2 and "nowhere" in capsys.readouterr().err


def test_depth_png_in_millimetres_reads_as_metres(tmp_path):
    Image.fromarray(np.array([[0, 1500], [20000, 700]], np.uint16)).save(tmp_path / "d.png")
    d = read_depth(tmp_path / "d.png", 0.001, ImportOptions())
    np.testing.assert_allclose(d, [[0, 1.5], [0, 0.7]])  # 20 m is beyond max_depth: invalid
