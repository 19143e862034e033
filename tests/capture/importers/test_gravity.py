"""Gravity in the importers: ``--up`` and a source's own gravity file refined by the floor, ``--max-tilt``,
the loud fallback when the cameras never see a floor, and empty or single-frame sources."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from flows.cli import main
from rescene_core.capture import open_capture
from rescene_core.capture.importers import ImportInputError, ImportOptions, import_capture, report_path
from rescene_core.capture.importers.common import read_source_gravity
from rescene_core.capture.importers.layouts import Y_UP_FROM_Z_UP, write_panoptic

Y_UP = [0.0, 1.0, 0.0]


def _angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def _y_up_source(tiny_scene, tmp_path: Path, keep_floor: bool = True) -> Path:
    """The tiny scene written as a y-up recorder (panoptic layout); without the floor's depth when asked."""
    a = tiny_scene.arrays
    if not keep_floor:
        floor = [int(i.id) for i in a.instances if i.label == "floor"]
        depth = np.where(np.isin(np.asarray(a.instance_masks), floor), 0.0, np.asarray(a.depth)).astype(np.float32)
        a = dataclasses.replace(a, depth=depth)
    return write_panoptic(a, tmp_path / "src", source_from_world=Y_UP_FROM_Z_UP)


def test_up_option_is_refined_by_the_floor_and_reported(tiny_scene, tmp_path, capsys):
    src = _y_up_source(tiny_scene, tmp_path)
    out = tmp_path / "out.zarr"
    # an IMU's up, 3 deg off the true +y: the floor plane near it corrects it
    off = [0.0, float(np.cos(np.radians(3.0))), float(np.sin(np.radians(3.0)))]
    assert main(["import", "panoptic", str(src), str(out), "--up", ",".join(map(str, off))]) == 0
    printed = capsys.readouterr().out
    assert "alignment: gravity+floor" in printed and "from the given up (--up)" in printed
    al = open_capture(out).attrs["alignment"]
    assert al["method"] == "gravity+floor" and al["prior"] == "gravity" and al["gravity_from"] == "--up"
    assert _angle(al["floor_normal_source"], Y_UP) < 0.5 and abs(al["floor_to_prior_up_deg"] - 3.0) < 0.5
    assert json.loads(report_path(out).read_text())["warnings"] == []


def test_gravity_file_of_the_source_is_read(tiny_scene, tmp_path):
    src = _y_up_source(tiny_scene, tmp_path)
    (src / "gravity.txt").write_text("0 -9.81 0\n")
    report = import_capture("panoptic", src, tmp_path / "out.zarr", ImportOptions())
    al = report["alignment"]
    assert al["method"] == "gravity+floor" and al["gravity_from"] == str(src / "gravity.txt")
    np.testing.assert_allclose(al["prior_up_source"], Y_UP)
    assert any("gravity read from" in n for n in report["notes"])
    # --up wins over the file, and the report says the file was not used
    report = import_capture("panoptic", src, tmp_path / "out2.zarr", ImportOptions(up=(0.0, 1.0, 0.001), max_tilt=5.0))
    assert report["alignment"]["gravity_from"] == "--up" and report["alignment"]["max_tilt_deg"] == 5.0
    assert any("is not" in n and "gravity.txt" in n for n in report["notes"])


def test_aria_trajectory_gravity_and_bad_gravity_files(tmp_path):
    rows = ["graph_uid,tx_world_device,gravity_x_world,gravity_y_world,gravity_z_world"]
    rows += [f"g,0.1,{gx},0,-9.81" for gx in (0.0, 0.01, -0.01)]
    (tmp_path / "closed_loop_trajectory.csv").write_text("\n".join(rows) + "\n")
    up, where = read_source_gravity(tmp_path)
    np.testing.assert_allclose(up, [0, 0, 1], atol=1e-9)
    assert where.endswith("closed_loop_trajectory.csv")
    (tmp_path / "gravity.txt").write_text("0 0\n")
    with pytest.raises(ImportInputError, match=r"gravity\.txt: gravity must be three finite numbers"):
        read_source_gravity(tmp_path)
    (tmp_path / "gravity.txt").write_text("down\n")
    with pytest.raises(ImportInputError, match=r"gravity\.txt: not three numbers"):
        read_source_gravity(tmp_path)
    assert read_source_gravity(tmp_path / "nothing-here") is None


def test_cameras_that_never_see_a_floor_get_a_loud_import(tiny_scene, tmp_path, capsys):
    src = _y_up_source(tiny_scene, tmp_path, keep_floor=False)
    out = tmp_path / "out.zarr"
    assert main(["import", "panoptic", str(src), str(out)]) == 0
    err = capsys.readouterr().err
    assert "WARNING: NO FLOOR FOUND" in err and "planes tried" in err
    assert "never see a floor" in err and "--up 0,1,0" in err  # the y-up source's axis nearest the cameras' up
    report = json.loads(report_path(out).read_text())
    assert report["alignment"]["method"] == "cameras"
    assert report["warnings"] == [report["alignment"]["warning"]] and "NO FLOOR FOUND" in report["warnings"][0]
    assert report["alignment"]["candidates"] and all(c["verdict"] for c in report["alignment"]["candidates"])
    # the fix it names works: the given up stands, and the import says the floor height is a guess
    assert main(["import", "panoptic", str(src), str(tmp_path / "fixed.zarr"), "--up", "0,1,0"]) == 0
    al = open_capture(tmp_path / "fixed.zarr").attrs["alignment"]
    assert al["method"] == "gravity" and _angle(al["floor_normal_source"], Y_UP) < 1e-6
    assert "no floor plane within 10 deg of the given up" in capsys.readouterr().err


def test_up_and_max_tilt_arguments_are_checked(tiny_scene, tmp_path, capsys):
    src = _y_up_source(tiny_scene, tmp_path)
    out = tmp_path / "out.zarr"
    assert main(["import", "panoptic", str(src), str(out), "--up", "0,1"]) == 2
    assert "three numbers x,y,z" in capsys.readouterr().err
    assert main(["import", "panoptic", str(src), str(out), "--up", "0,0,0"]) == 2
    assert "not all zero" in capsys.readouterr().err
    assert main(["import", "panoptic", str(src), str(out), "--max-tilt", "-3"]) == 2
    assert "--max-tilt -3" in capsys.readouterr().err
    assert main(["import", "panoptic", str(src), str(out), "--up", "0,1,0", "--align", "none"]) == 2
    assert "need --align floor" in capsys.readouterr().err
    assert not out.exists()


def test_empty_and_single_frame_sources_name_the_file(tiny_scene, tmp_path):
    src = write_panoptic(tiny_scene.arrays, tmp_path / "src")
    poses = (src / "poses.txt").read_text().splitlines()
    (src / "poses.txt").write_text("")
    with pytest.raises(ImportInputError, match=r"poses\.txt: no poses \(the file is empty\)"):
        import_capture("panoptic", src, tmp_path / "out.zarr")
    # one frame (a view 44 deg down at the desk): the floor is still found, and the report says it is one view
    for sub in ("images", "depth", "instances"):
        for p in (src / sub).iterdir():
            if p.stem != "00006":
                p.unlink()
    (src / "poses.txt").write_text(poses[6] + "\n")
    report = import_capture("panoptic", src, tmp_path / "one.zarr")
    assert report["frames"]["kept"] == 1 and any("a single frame (00006)" in n for n in report["notes"])
    assert (
        report["alignment"]["method"] == "floor" and _angle(report["alignment"]["floor_normal_source"], [0, 0, 1]) < 1
    )
    assert report["alignment"]["floor_to_camera_up_deg"] > 40
    # --max-tilt below that view's 44 deg: the floor is rejected for its tilt alone, and the warning says so
    report = import_capture("panoptic", src, tmp_path / "tight.zarr", ImportOptions(max_tilt=20.0))
    assert report["alignment"]["method"] == "cameras" and report["alignment"]["max_tilt_deg"] == 20.0
    assert (
        "44.4 deg from the cameras' up was rejected only for its tilt: --max-tilt 46 accepts it (now 20)"
        in (report["warnings"][0])
    )
    report = import_capture("panoptic", src, tmp_path / "loose.zarr", ImportOptions(max_tilt=46.0))
    assert report["alignment"]["method"] == "floor" and not report["warnings"]
    with pytest.raises(ImportInputError, match=r"a single frame \(00006\).*--segment geometric"):
        import_capture("rgbd", src, tmp_path / "geo.zarr", ImportOptions(segment="geometric"))
    with pytest.raises(ImportInputError, match="--max-frames is 0"):
        import_capture("panoptic", src, tmp_path / "none.zarr", ImportOptions(max_frames=0))
