"""Object names from free-text labels: one valid, unique name per object in every export (files, USD prims,
MJCF bodies, glTF nodes), the label kept verbatim beside it, and the readers (physics check, evaluation,
VQA) still finding every object."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rescene_core.assets import save_asset
from rescene_core.config import SimcheckConfig
from rescene_core.evaluation.scene import load_scene
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.gltf import split_glb, validate_gltf
from rescene_core.export.mjcf import mjcf_labels
from rescene_core.export.scene import export_run
from rescene_core.export.usd import LABEL_KEY, validate_usd
from rescene_core.geometry import sim3
from rescene_core.io import write_json_atomic
from rescene_core.names import MAX_SLUG_CHARS, check_unique, label_slug, node_name
from rescene_core.records import Asset, Edge, InstanceId, Layout, Plane, Relation, RoomShell, Root, SceneGraph
from rescene_core.sim.check import simcheck_run
from rescene_core.vqa import read_run

mujoco = pytest.importorskip("mujoco")
pxr = pytest.importorskip("pxr")

LONG = "a very long label that someone typed / with slashes, dots. and spaces " * 4
LABELS = {
    1: "part of a cabinet/wardrobe",
    2: "crème brûlée jar",
    3: "3 books",
    4: "chair",
    5: "chair",
    6: "",
    7: LONG,
    8: "Chair",
    9: "shelf.v2\\left",
}
NAMES = {
    1: "obj_1_part_of_a_cabinet_wardrobe",
    2: "obj_2_creme_brulee_jar",
    3: "obj_3_3_books",
    4: "obj_4_chair",
    5: "obj_5_chair",
    6: "obj_6",
    7: "obj_7_a_very_long_label_that_someone_typed___with_slashes__dots__and_s",
    8: "obj_8_Chair",
    9: "obj_9_shelf_v2_left",
}
SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    ceiling_height=2.5,
)


def test_plain_labels_keep_their_names():
    assert node_name(12, "chair") == "obj_12_chair"
    assert node_name(3, "night stand") == "obj_3_night_stand"
    assert node_name(7, "book_stack") == "obj_7_book_stack"


def test_invalid_characters_are_replaced():
    from pxr import Tf

    assert {i: node_name(i, label) for i, label in LABELS.items()} == NAMES
    assert node_name(4, "//") == "obj_4"
    assert node_name(4, "椅子") == "obj_4"
    assert node_name(4, "ﬁle cabinet") == "obj_4_file_cabinet"  # compatibility forms become ASCII
    assert len(label_slug(LONG)) == MAX_SLUG_CHARS
    for name in NAMES.values():
        assert Tf.IsValidIdentifier(name), name


def test_names_are_unique_ignoring_case_and_a_repeated_id_is_refused():
    names = check_unique(LABELS.items())
    assert len({n.casefold() for n in names.values()}) == len(LABELS)
    with pytest.raises(ValueError, match="instance ids must be unique"):
        check_unique([(4, "chair"), (4, "Chair")])
    with pytest.raises(ValueError, match="negative"):
        node_name(-1, "chair")


def _objects() -> list[ExportObject]:
    """A 0.3 m box per label standing on the floor, 0.7 m apart."""
    box = trimesh.creation.box((0.3, 0.3, 0.3))
    out = []
    for k, (i, label) in enumerate(sorted(LABELS.items())):
        pose = sim3.sim3_from_parts(1.0, np.eye(3), [-1.4 + 0.7 * (k % 5), -0.7 + 1.4 * (k // 5), 0.15])
        out.append(ExportObject(i, label, np.asarray(box.vertices), np.asarray(box.faces), pose))
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    """A run directory: assets, layout, shell and graph as a run writes them, and the scene exported."""
    run = tmp_path_factory.mktemp("run")
    objects = _objects()
    graph = SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR) for i in LABELS))
    for o in objects:
        folder = run / "instances" / str(o.instance)
        save_asset(folder / "asset.glb", Asset(InstanceId(o.instance), o.vertices, o.faces, "test"))
        write_json_atomic(folder / "asset.json", {"instance": o.instance, "glb": "asset.glb"})
    write_json_atomic(run / "shell.json", SHELL.to_json())
    write_json_atomic(run / "scenegraph" / "graph.json", graph.to_json())
    write_json_atomic(
        run / "layout.json", Layout({InstanceId(o.instance): o.world_from_asset for o in objects}).to_json()
    )
    config = ExportConfig(decomposition_cache=str(run / "cache"))
    export_scene(run / "scene", objects, SHELL, graph, [], config)
    return run


def test_files_lie_directly_in_their_folders(run):
    scene = run / "scene"
    objects = sorted(p.relative_to(scene / "objects").as_posix() for p in (scene / "objects").rglob("*"))
    assert objects == sorted(f"{n}.glb" for n in NAMES.values())
    meshes = list((scene / "mjcf" / "meshes").rglob("*"))
    assert meshes and all(p.is_file() and p.parent == scene / "mjcf" / "meshes" for p in meshes)
    stems = {p.stem.split("_col")[0] for p in meshes}
    assert stems == set(NAMES.values())
    assert len({p.name.casefold() for p in meshes}) == len(meshes)


def test_scene_json_keeps_labels_and_names(run):
    doc = json.loads((run / "scene" / "scene.json").read_text(encoding="utf-8"))
    got = {o["instance"]: (o["label"], o["node"], o["mesh"]) for o in doc["objects"]}
    assert got == {i: (LABELS[i], NAMES[i], f"objects/{NAMES[i]}.glb") for i in LABELS}


def test_usd_prims_are_children_of_the_objects_scope_with_the_label(run):
    from pxr import Usd

    path = run / "scene" / "scene.usda"
    stage = Usd.Stage.Open(str(path))
    scope = stage.GetPrimAtPath("/World/Objects")
    children = {p.GetName(): p for p in scope.GetChildren()}
    assert set(children) == set(NAMES.values())
    for i, name in NAMES.items():
        prim = children[name]
        assert prim.GetCustomDataByKey(LABEL_KEY) == LABELS[i]
        assert prim.GetAttribute("rescene:label").Get() == LABELS[i]
        assert prim.GetDisplayName() == LABELS[i]
        assert prim.GetAttribute("rescene:instance").Get() == i
    assert all(p.GetPath().pathElementCount == 3 for p in children.values())
    assert validate_usd(path) == []


def test_mjcf_bodies_meshes_and_labels(run):
    model = mujoco.MjModel.from_xml_path(str(run / "scene" / "mjcf" / "scene.xml"))
    bodies = {model.body(b).name for b in range(1, model.nbody)}
    assert bodies == set(NAMES.values())
    meshes = {model.mesh(m).name for m in range(model.nmesh)}
    assert {f"{n}/visual" for n in NAMES.values()} <= meshes
    # the label verbatim, for every object but the one whose label is empty
    assert mjcf_labels(model) == {NAMES[i]: LABELS[i] for i in LABELS if LABELS[i]}


def test_glb_nodes_carry_the_label_and_validate(run):
    scene_glb = run / "scene" / "scene.glb"
    doc, _ = split_glb(scene_glb.read_bytes())
    extras = {n["name"]: n.get("extras", {}) for n in doc["nodes"]}
    for i, name in NAMES.items():
        assert extras[name]["label"] == LABELS[i] and extras[name]["instance"] == i
    loaded = trimesh.load(scene_glb, force="scene")
    assert set(NAMES.values()) <= set(loaded.graph.nodes_geometry)
    for path in [scene_glb, *sorted((run / "scene" / "objects").glob("*.glb"))]:
        report = validate_gltf(path)
        assert report.errors == 0, (path.name, report.messages)


def test_readers_find_every_object(run):
    check = simcheck_run(run, SimcheckConfig(seconds=0.5))
    assert {o.node for o in check.objects} == set(NAMES.values())
    assert all(o.stable for o in check.objects)
    loaded = load_scene(run)
    assert {int(o.instance): o.label for o in loaded.scene.objects} == LABELS
    vqa = read_run(run)
    assert {o.id: o.label for o in vqa.objects} == LABELS


def test_export_again_from_the_run_keeps_the_names(run):
    before = json.loads((run / "scene" / "scene.json").read_text(encoding="utf-8"))["objects"]
    export_run(run, ExportConfig(decomposition_cache=str(run / "cache"), simulation=False))
    after = json.loads((run / "scene" / "scene.json").read_text(encoding="utf-8"))["objects"]
    assert [(o["label"], o["node"]) for o in after] == [(o["label"], o["node"]) for o in before]
