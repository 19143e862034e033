"""MJCF (MuJoCo loads and steps it), USD (pxr opens it, UsdValidation reports no errors) and the export
report, including the fallbacks for bad meshes."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.colliders.decompose import DecompositionSettings, decompose
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.usd import validate_usd
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Missing, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

mujoco = pytest.importorskip("mujoco")
pxr = pytest.importorskip("pxr")

SHELL = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(
        WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),
        WallPlane(1, Plane((-1.0, 0.0, 0.0), 2.0), ((2.0, -2.0), (2.0, 2.0))),
    ),
    floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    ceiling_height=2.5,
)


def table_mesh():
    """A table: top 1.0 x 0.6 x 0.05 on four legs, 0.75 high, origin at the bottom centre (concave)."""
    parts = [trimesh.creation.box((1.0, 0.6, 0.05), trimesh.transformations.translation_matrix([0, 0, 0.725]))]
    for x in (-0.45, 0.45):
        for y in (-0.25, 0.25):
            parts.append(
                trimesh.creation.box((0.05, 0.05, 0.7), trimesh.transformations.translation_matrix([x, y, 0.35]))
            )
    return trimesh.boolean.union(parts, engine="manifold")


def scene_objects():
    table = table_mesh()
    cup = trimesh.creation.cylinder(radius=0.05, height=0.1, sections=16)
    frame = trimesh.creation.box((0.6, 0.02, 0.4))
    flat = trimesh.Trimesh([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0]], [[0, 1, 2]])  # a single triangle
    return [
        ExportObject(
            1, "dining table", table.vertices, table.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0, 0, 0.0005])
        ),
        ExportObject(2, "mug", cup.vertices, cup.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0.2, 0.1, 0.801])),
        ExportObject(3, "picture", frame.vertices, frame.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0, -1.989, 1.5])),
        ExportObject(4, "sheet", flat.vertices, flat.faces, sim3.sim3_from_parts(1.0, np.eye(3), [-1, 1, 0.01])),
    ]


GRAPH = SceneGraph(
    (
        Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR),
        Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1)),
        Edge(InstanceId(3), Relation.MOUNTS_ON, Root.WALL, wall_id=0),
    )
)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("scene")
    config = ExportConfig(decomposition_cache=str(out / "cache"))
    hashes = export_scene(out, scene_objects(), SHELL, GRAPH, [Missing(InstanceId(9), "registration", "gates")], config)
    return out, hashes


def test_mjcf_loads_steps_and_has_the_right_bodies(exported):
    out, hashes = exported
    assert {"mjcf/scene.xml", "scene.usda", "export_report.json"} <= set(hashes)
    model = mujoco.MjModel.from_xml_path(str(out / "mjcf/scene.xml"))
    data = mujoco.MjData(model)
    free = {model.body(int(model.jnt_bodyid[j])).name for j in range(model.njnt)}
    assert free == {"obj_1_dining_table", "obj_2_mug", "obj_4_sheet"}  # the picture is mounted: no joint
    table = model.body("obj_1_dining_table")
    # mass = bulk density x closed volume (0.03 + 4 * 0.00175 m^3)
    assert model.body_mass[table.id] == pytest.approx(120.0 * (1.0 * 0.6 * 0.05 + 4 * 0.05 * 0.05 * 0.7), rel=1e-3)
    visual = model.geom("obj_1_dining_table/visual")
    assert model.geom_contype[visual.id] == 0 and model.geom_conaffinity[visual.id] == 0
    pieces = [g for g in range(model.ngeom) if model.geom(g).name.startswith("obj_1_dining_table/col")]
    assert len(pieces) >= 3  # a concave table is not one hull
    assert model.geom_friction[pieces[0]][0] == pytest.approx(0.5)
    for _ in range(500):
        mujoco.mj_step(model, data)
    assert np.isfinite(data.qpos).all()
    # the mug stays on the table top (it would sink to the floor without the top's collider)
    assert data.xpos[model.body("obj_2_mug").id][2] > 0.75


def test_usd_opens_and_validates(exported):
    from pxr import Usd, UsdGeom, UsdPhysics

    out, _ = exported
    stage = Usd.Stage.Open(str(out / "scene.usda"))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert validate_usd(out / "scene.usda") == []
    table = stage.GetPrimAtPath("/World/Objects/obj_1_dining_table")
    picture = stage.GetPrimAtPath("/World/Objects/obj_3_picture")
    assert table.HasAPI(UsdPhysics.RigidBodyAPI) and table.HasAPI(UsdPhysics.MassAPI)
    assert not picture.HasAPI(UsdPhysics.RigidBodyAPI)  # mounted: a static collider
    assert table.GetAttribute("rescene:relation").Get() == "rests-on"
    mug = stage.GetPrimAtPath("/World/Objects/obj_2_mug")
    assert mug.GetAttribute("rescene:parent").Get() == "1"
    piece = stage.GetPrimAtPath("/World/Objects/obj_1_dining_table/collision_0")
    assert piece.HasAPI(UsdPhysics.CollisionAPI)
    assert UsdPhysics.MeshCollisionAPI(piece).GetApproximationAttr().Get() == "convexHull"
    assert any(p.IsA(UsdPhysics.Scene) for p in stage.Traverse())
    floor = stage.GetPrimAtPath("/World/Shell/shell_floor")
    assert floor.HasAPI(UsdPhysics.CollisionAPI) and not floor.HasAPI(UsdPhysics.RigidBodyAPI)


def test_usd_validation_can_fail(tmp_path):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "bad.usda"))
    UsdGeom.Xform.Define(stage, "/World")
    stage.GetRootLayer().Save()
    errors = validate_usd(tmp_path / "bad.usda")
    assert any("UpAxis" in e or "MetersPerUnit" in e or "DefaultPrim" in e for e in errors)


def test_report_names_every_guess(exported):
    out, _ = exported
    report = json.loads((out / "export_report.json").read_text())
    by_node = {o["node"]: o for o in report["objects"]}
    assert by_node["obj_1_dining_table"]["collision_method"] == "components"  # a union of boxes: exact
    assert any("default" in n and "density" in n for n in by_node["obj_2_mug"]["notes"])  # 'mug' has no entry
    sheet = by_node["obj_4_sheet"]
    assert sheet["collision_method"] == "box" and any("flat or degenerate" in n for n in sheet["notes"])
    assert any("visual mesh left out" in n for n in sheet["notes"])
    assert report["missing"] == [{"instance": 9, "stage": "registration", "reason": "gates"}]


def slanted_table():
    """The table turned 30 degrees about z: no longer axis-aligned boxes, so it goes to CoACD."""
    table = table_mesh()
    table.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
    return table


def test_coacd_timeout_falls_back_to_the_hull(tmp_path):
    table = slanted_table()
    settings = DecompositionSettings(timeout_s=0.01, cache_dir=str(tmp_path))
    dec = decompose(table.vertices, table.faces, settings)
    assert dec.method == "hull" and len(dec.pieces) == 1
    assert any("no result within" in n for n in dec.notes)


def test_decompositions_are_cached(tmp_path):
    table = slanted_table()
    settings = DecompositionSettings(cache_dir=str(tmp_path))
    first = decompose(table.vertices, table.faces, settings)
    again = decompose(table.vertices, table.faces, settings)
    assert first.method == "coacd" and not first.cached and again.cached and again.method == first.method
    assert len(again.pieces) == len(first.pieces) and again.volume == pytest.approx(first.volume, rel=1e-9)


def test_bad_mesh_values_never_raise(tmp_path):
    nan = np.full((4, 3), np.nan)
    dec = decompose(nan, np.array([[0, 1, 2], [0, 2, 3]]), DecompositionSettings(cache_dir=str(tmp_path)))
    assert dec.method == "box" and dec.notes
