"""ScanNet and nerfstudio layouts: synthetic captures written out and imported back (poses, intrinsics,
masks and depth identical within tolerance), ScanNet's -inf poses dropped and counted, masks rendered
from the 3D annotation, and clear errors for bad layouts."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from rescene_core.capture import open_capture
from rescene_core.capture.importers import ImportInputError, ImportOptions, import_capture
from rescene_core.capture.importers.layouts import (
    write_nerfstudio,
    write_panoptic,
    write_scannet,
    write_scannet_mesh_annotation,
)
from rescene_core.capture.importers.scannet import read_scannet

NO_ALIGN = ImportOptions(align="none")


def _same_frames(cap, a, frames=None):
    frames = list(range(len(a.rgb))) if frames is None else frames
    np.testing.assert_allclose(cap.world_from_cam, a.world_from_cam[frames], atol=1e-9)
    np.testing.assert_allclose(cap.K, a.K[frames], atol=1e-9)
    np.testing.assert_allclose(np.asarray(cap.depth[...]), a.depth[frames], atol=5e-4)


def test_scannet_2d_round_trip_drops_inf_poses(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    src = write_scannet(a, tmp_path / "scene", inf_pose_frames=(3, 8))
    report = import_capture("scannet", src, tmp_path / "out.zarr", NO_ALIGN)
    cap = open_capture(tmp_path / "out.zarr")
    kept = [t for t in range(len(a.rgb)) if t not in (3, 8)]
    _same_frames(cap, a, kept)
    np.testing.assert_array_equal(np.asarray(cap.instance_masks[...]), a.instance_masks[kept])
    assert report["frames"]["dropped"] == 2
    assert report["frames"]["dropped_by_reason"] == {"pose has NaN or infinite values": 2}
    assert [d["frame"] for d in report["frames"]["dropped_frames"]] == [3, 8]
    # labels come from label-filt through the label map, structure is recognised
    truth = {int(i.id): (i.label, i.structural) for i in a.instances}
    for inst in cap.instances:
        assert (inst.label, inst.structural) == truth[int(inst.id)]
    assert any("colour resized to the depth resolution" in n for n in report["notes"])
    assert cap.source == "scannet-masks"


def test_scannet_3d_annotation_is_rendered_into_each_camera(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    src = write_scannet(a, tmp_path / "scene")
    shutil.rmtree(src / "instance-filt")
    shutil.rmtree(src / "label-filt")
    by_object = write_scannet_mesh_annotation(tiny_scene, src)
    import_capture("scannet", src, tmp_path / "out.zarr", NO_ALIGN)
    cap = open_capture(tmp_path / "out.zarr")
    masks = np.asarray(cap.instance_masks[...])
    truth = tiny_scene.object_id_frames
    for oid, iid in by_object.items():
        gt = truth == oid
        if gt.sum() < 200:
            continue
        iou = (gt & (masks == iid)).sum() / (gt | (masks == iid)).sum()
        assert iou > 0.8, (oid, iid, iou)
    labels = {int(i.id): i.label for i in cap.instances}
    assert {labels[i] for i in by_object.values() if i in labels} <= {o.label for o in tiny_scene.gt.objects}


def test_scannet_without_any_annotation_names_the_fix(tiny_scene, tmp_path):
    src = write_scannet(tiny_scene.arrays, tmp_path / "scene")
    shutil.rmtree(src / "instance-filt")
    with pytest.raises(ImportInputError, match=r"aggregation\.json.*--segment geometric"):
        read_scannet(src, ImportOptions())
    (src / "pose" / "4.txt").unlink()
    with pytest.raises(ImportInputError, match=r"pose: .*4\.jpg"):
        read_scannet(src, ImportOptions(segment="geometric"))


def test_nerfstudio_round_trip_converts_opengl_cameras(tiny_scene, tmp_path):
    a = tiny_scene.arrays
    src = write_panoptic(a, tmp_path / "p")  # instance PNGs and labels for the panoptic import below
    ns = write_nerfstudio(a, tmp_path / "ns")
    shutil.copytree(src / "instances", ns / "instances")
    for p in sorted((ns / "instances").iterdir()):  # name the masks like the nerfstudio frames
        p.rename(p.with_name(f"frame_{int(p.stem) + 1:05d}.png"))
    shutil.copy(src / "labels.json", ns / "labels.json")
    report = import_capture("panoptic", ns, tmp_path / "out.zarr", NO_ALIGN)
    cap = open_capture(tmp_path / "out.zarr")
    _same_frames(cap, a)
    np.testing.assert_array_equal(np.asarray(cap.instance_masks[...]), a.instance_masks)
    assert "frames read in the nerfstudio layout" in report["notes"]


def test_nerfstudio_bad_input(tiny_scene, tmp_path):
    ns = write_nerfstudio(tiny_scene.arrays, tmp_path / "ns")
    meta = json.loads((ns / "transforms.json").read_text())
    meta["k1"] = 0.1
    (ns / "transforms.json").write_text(json.dumps(meta))
    with pytest.raises(ImportInputError, match="distorted.*undistort"):
        import_capture("nerfstudio", ns, tmp_path / "o.zarr", ImportOptions(segment="geometric"))
    meta["k1"] = 0.0
    meta["frames"][2]["file_path"] = "images/nope.png"
    (ns / "transforms.json").write_text(json.dumps(meta))
    with pytest.raises(ImportInputError, match=r"nope\.png: image is missing"):
        import_capture("nerfstudio", ns, tmp_path / "o.zarr", ImportOptions(segment="geometric"))
    assert not (tmp_path / "o.zarr").exists()


def test_panoptic_labels_file_is_checked(tiny_scene, tmp_path):
    src = write_panoptic(tiny_scene.arrays, tmp_path / "p")
    (src / "labels.json").write_text('{"x": "chair"}')
    with pytest.raises(ImportInputError, match=r"labels\.json: instance id 'x'"):
        import_capture("panoptic", src, tmp_path / "o.zarr", NO_ALIGN)
    (src / "labels.json").unlink()
    with pytest.raises(ImportInputError, match=r"labels\.json is missing"):
        import_capture("panoptic", src, tmp_path / "o.zarr", NO_ALIGN)


def test_panoptic_with_only_structure_is_an_empty_scene(tiny_scene, tmp_path):
    src = write_panoptic(tiny_scene.arrays, tmp_path / "p")
    table = json.loads((src / "labels.json").read_text())
    (src / "labels.json").write_text(json.dumps([{**r, "structural": True} for r in table]))
    with pytest.raises(ImportInputError, match="empty scene: no object instance"):
        import_capture("panoptic", src, tmp_path / "o.zarr", NO_ALIGN)
    assert not (tmp_path / "o.zarr").exists()
