"""Run-log segments, merging, SceneUpdate snapshots and the `rescene log` summary."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from mcap.reader import make_reader

from rescene_core.records import Plane, RoomShell, WallPlane
from rescene_core.runlog import SceneObject, Segment, merge_segments, read_messages, scene_update
from rescene_core.runlog.summary import summarise

SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    ceiling_height=2.5,
)


def test_segments_merge_in_time_order(tmp_path):
    a = Segment(tmp_path, "registration-000003")
    b = Segment(tmp_path, "flow")
    a.log("/registration/gates", {"instance": 3, "method": "icp", "diagnostics": {"rmse": 0.01}}, log_time_ns=30)
    b.log("/flow/events", {"event": "start"}, log_time_ns=10)
    b.log("/flow/events", {"event": "end", "state": "Completed", "missing": []}, log_time_ns=40)
    a.log("/metrics", {"stage": "registration", "metrics": {"rmse": 0.01}}, log_time_ns=20)
    a.close()
    b.close()
    path = merge_segments(tmp_path)
    msgs = read_messages(path)
    assert [t for _, t, _ in msgs] == [10, 20, 30, 40]
    assert msgs[2][2]["diagnostics"]["rmse"] == 0.01
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert {c.topic for c in summary.channels.values()} == {"/registration/gates", "/flow/events", "/metrics"}
    assert all(s.encoding == "jsonschema" for s in summary.schemas.values())


def test_unknown_topic_is_rejected(tmp_path):
    with pytest.raises(KeyError, match="unknown run-log topic"):
        Segment(tmp_path, "x").log("/nope", {})


def test_reexecuted_task_replaces_its_segment(tmp_path):
    for k in range(2):
        with Segment(tmp_path, "asset-000001") as seg:
            seg.log("/assets/generation", {"instance": 1, "backend": f"b{k}", "vertices": 8, "faces": 12})
    msgs = read_messages(merge_segments(tmp_path))
    assert [m["backend"] for _, _, m in msgs] == ["b1"]


def test_scene_update_entities():
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    m = np.eye(4)
    m[:3, :3] *= 0.5
    m[:3, 3] = [1.0, 0.0, 0.25]
    obj = SceneObject(7, "chair", np.asarray(box.vertices), np.asarray(box.faces), m)
    update = scene_update([obj], SHELL, 1_500_000_000, wall_height=2.5, wall_thickness=0.05)
    ids = [e["id"] for e in update["entities"]]
    assert ids == ["obj_7_chair", "shell_floor", "shell_wall_0"]
    ent = update["entities"][0]
    assert ent["timestamp"] == {"sec": 1, "nsec": 500_000_000} and ent["frame_id"] == "world"
    tri = ent["triangles"][0]
    assert len(tri["indices"]) == 3 * len(box.faces) and len(tri["points"]) == len(box.vertices)
    zs = [p["z"] for p in tri["points"]]
    assert min(zs) == pytest.approx(0.0) and max(zs) == pytest.approx(0.5)
    cube = ent["cubes"][0]
    assert cube["size"] == pytest.approx({"x": 0.5, "y": 0.5, "z": 0.5})
    assert cube["pose"]["position"] == pytest.approx({"x": 1.0, "y": 0.0, "z": 0.25})
    wall = update["entities"][2]["cubes"][0]
    assert wall["size"]["x"] == pytest.approx(4.0) and wall["size"]["z"] == pytest.approx(2.5)


def test_log_command_summarises(tmp_path, capsys):
    from flows.cli import main

    assert main(["log", str(tmp_path)]) == 2
    seg = Segment(tmp_path, "flow")
    seg.log("/flow/tasks", {"stage": "registration", "item": 3, "state": "Completed", "cached": False})
    seg.log("/flow/tasks", {"stage": "registration", "item": 4, "state": "Cached", "cached": True})
    missing = [{"instance": 5, "stage": "asset", "reason": "no depth"}]
    seg.log("/flow/events", {"event": "end", "state": "Failed", "message": "instances failed: 5", "missing": missing})
    seg.log("/metrics", {"stage": "evaluation", "metrics": {"recall": 0.75}})
    seg.close()
    merge_segments(tmp_path)
    s = summarise(tmp_path)
    assert s["stages"]["registration"] == {"completed": 1, "cached": 1}
    assert s["state"] == "Failed" and s["missing"] == missing and s["metrics"]["evaluation"]["recall"] == 0.75
    assert main(["log", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "missing instances (1)" in out and "no depth" in out
