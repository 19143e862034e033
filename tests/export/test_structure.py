"""Built-in structure: a counter backed onto a wall is fixed to the world; movable furniture, a counter
standing free in the room and a short piece by a wall stay free bodies."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.mjcf import body_kind
from rescene_core.export.simulation import structure_rule
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-3.0, -2.0), (3.0, -2.0))),),
    floor_polygon=((-3.0, -2.0), (3.0, -2.0), (3.0, 2.0), (-3.0, 2.0)),
    ceiling_height=2.5,
)


def _box(instance: int, label: str, size, centre_xy) -> ExportObject:
    box = trimesh.creation.box(size)
    pose = sim3.sim3_from_parts(1.0, np.eye(3), [centre_xy[0], centre_xy[1], size[2] / 2])
    return ExportObject(instance, label, np.asarray(box.vertices), np.asarray(box.faces), pose)


def _on_floor(*objects: ExportObject) -> SceneGraph:
    return SceneGraph(tuple(Edge(InstanceId(o.instance), Relation.RESTS_ON, Root.FLOOR) for o in objects))


RULE = structure_rule(ExportConfig())


def test_an_unlabelled_counter_backed_onto_a_wall_is_fixed():
    counter = _box(1, "object", (2.4, 0.6, 0.9), (0.0, -1.69))  # its back 1 cm from the wall
    kind, notes = body_kind(counter, _on_floor(counter), SHELL, RULE)
    assert kind == "fixed" and "built-in structure" in notes[0] and "wall 0" in notes[0]
    labelled = _box(1, "Kitchen Counter", (2.4, 0.6, 0.9), (0.0, -1.69))
    assert body_kind(labelled, _on_floor(labelled), SHELL, RULE)[0] == "fixed"
    # without the rule only mounts are fixed
    assert body_kind(counter, _on_floor(counter), SHELL)[0] == "free"


@pytest.mark.parametrize(
    ("label", "size", "centre", "why"),
    [
        ("desk", (2.4, 0.6, 0.9), (0.0, -1.69), "a labelled piece of movable furniture"),
        ("object", (2.4, 0.6, 0.9), (0.0, 0.0), "standing free in the room"),
        ("object", (0.5, 0.5, 0.9), (0.0, -1.74), "a short piece by the wall"),
        ("object", (2.4, 0.6, 0.4), (0.0, -1.69), "its top below counter height"),
        ("object", (2.4, 0.6, 2.0), (0.0, -1.69), "its top above counter height"),
    ],
)
def test_what_is_not_built_in_stays_free(label, size, centre, why):
    obj = _box(1, label, size, centre)
    assert body_kind(obj, _on_floor(obj), SHELL, RULE)[0] == "free", why


def test_a_counter_resting_on_another_object_stays_free():
    counter = _box(1, "object", (2.4, 0.6, 0.9), (0.0, -1.69))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, InstanceId(2)),))
    assert body_kind(counter, graph, SHELL, RULE)[0] == "free"


def test_the_export_fixes_the_counter_and_says_why(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    pytest.importorskip("pxr")
    counter = _box(1, "object", (2.4, 0.6, 0.9), (0.0, -1.69))
    crate = _box(2, "object", (0.4, 0.4, 0.3), (0.0, 1.0))
    export_scene(tmp_path, [counter, crate], SHELL, _on_floor(counter, crate), [], ExportConfig())
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "mjcf/scene.xml"))
    free = {model.body(int(model.jnt_bodyid[j])).name for j in range(model.njnt)}
    report = json.loads((tmp_path / "export_report.json").read_text())
    kinds = {o["instance"]: o["kind"] for o in report["objects"]}
    assert kinds == {1: "fixed", 2: "free"}
    names = {o["instance"]: o["node"] for o in report["objects"]}
    assert free == {names[2]}
    (entry,) = [o for o in report["objects"] if o["instance"] == 1]
    assert any("built-in structure" in n for n in entry["notes"])
