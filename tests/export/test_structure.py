"""Built-in structure: a counter backed onto a wall, alone or as units of a fitted run, is fixed to the world;
movable furniture, a counter standing free in the room and a short piece by a wall stay free bodies."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.mjcf import body_kind
from rescene_core.export.simulation import structure_rule
from rescene_core.export.structure import built_in
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


def _kind(*objects: ExportObject, graph: SceneGraph | None = None, rule=RULE) -> dict[int, str]:
    graph = graph or _on_floor(*objects)
    fixed = built_in(objects, graph, SHELL, rule)
    return {o.instance: body_kind(o.instance, graph, fixed)[0] for o in objects}


def test_an_unlabelled_counter_backed_onto_a_wall_is_fixed():
    counter = _box(1, "object", (2.4, 0.6, 0.9), (0.0, -1.69))  # its back 1 cm from the wall
    graph = _on_floor(counter)
    (reason,) = built_in([counter], graph, SHELL, RULE).values()
    assert "built-in structure" in reason and "wall 0" in reason
    assert body_kind(1, graph, {1: reason}) == ("fixed", [reason])
    assert _kind(_box(1, "Kitchen Counter", (2.4, 0.6, 0.9), (0.0, -1.69))) == {1: "fixed"}
    # without the rule (no built-in list) only mounted objects are fixed
    assert body_kind(1, graph)[0] == "free"


def test_the_units_of_a_fitted_run_are_fixed_together():
    # three 0.8 m units side by side: each shorter than the 1 m a run needs, together 2.4 m
    units = [_box(k + 1, "kitchen counter", (0.8, 0.6, 0.9), (-0.8 + 0.8 * k, -1.69)) for k in range(3)]
    assert _kind(*units) == {1: "fixed", 2: "fixed", 3: "fixed"}
    # one unit alone is a cabinet by a wall; two with a 0.3 m gap between them are two
    assert _kind(units[0]) == {1: "free"}
    apart = _box(3, "kitchen counter", (0.8, 0.6, 0.9), (1.1, -1.69))
    assert _kind(units[0], apart) == {1: "free", 3: "free"}


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
    assert _kind(_box(1, label, size, centre)) == {1: "free"}, why


def test_a_counter_resting_on_another_object_stays_free():
    counter = _box(1, "object", (2.4, 0.6, 0.9), (0.0, -1.69))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, InstanceId(2)),))
    assert _kind(counter, graph=graph) == {1: "free"}


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
