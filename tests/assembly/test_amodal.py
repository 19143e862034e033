"""Amodal completion: a kitchen island seen only from above (its worktop, nothing of its body) is completed
down to the floor under its whole footprint, and stands in MuJoCo with a cup on it."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import trimesh
from shapely.geometry import MultiPoint

from rescene_core.assembly import attach
from rescene_core.assembly.objects import AssemblyObject
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.config import AttachmentConfig, ExportConfig
from rescene_core.export import export_scene
from rescene_core.export.objects import placed_objects
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

TOP = 0.92
"""Height of the island's worktop (m)."""


def island_seen_from_above(rng: np.random.Generator) -> AssemblyObject:
    """A generated island as a single view from above makes it: a worktop slab 1.8 x 0.95 x 0.024 m with a
    5 cm lip along its front edge (the edge the view grazed), its points on the worktop only."""
    slab = trimesh.creation.box((1.8, 0.95, 0.024), trimesh.transformations.translation_matrix([0, 0, -0.012]))
    lip = trimesh.creation.box((1.8, 0.03, 0.05), trimesh.transformations.translation_matrix([0, -0.46, -0.049]))
    mesh = trimesh.boolean.union([slab, lip], engine="manifold")
    pose = placed(2.0, 2.5, TOP)
    top = np.c_[rng.uniform(1.1, 2.9, 3000), rng.uniform(2.03, 2.97, 3000), rng.normal(TOP, 0.003, 3000)]
    obj = AssemblyObject(InstanceId(1), "kitchen island", np.asarray(mesh.vertices), np.asarray(mesh.faces), pose)
    return replace(obj, exact_shape=False, points=top)


def _scene():
    rng = np.random.default_rng(0)
    island = island_seen_from_above(rng)
    cup = box_object(2, "coffee cup", (0.08, 0.08, 0.1), placed(2.3, 2.6, TOP), exact_shape=False)
    cup_pts = np.c_[rng.uniform(2.26, 2.34, 300), rng.uniform(2.56, 2.64, 300), rng.uniform(TOP, TOP + 0.1, 300)]
    cup = replace(cup, points=cup_pts)
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.9),
        )
    )
    return {InstanceId(1): island, InstanceId(2): cup}, graph, rect_room()


def test_an_island_seen_only_from_above_is_a_block_down_to_the_floor():
    objects, graph, shell = _scene()
    layout = attach(objects, graph, shell, AttachmentConfig())
    pose = layout.world_from_asset[InstanceId(1)]
    np.testing.assert_allclose(pose, objects[InstanceId(1)].world_from_asset, atol=1e-6)  # kept where seen
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    assert "seen only from above" in base.source
    world = apply(pose, base.points_asset)
    assert abs(world[:, 2].min()) < 1e-6  # on the floor
    assert world[:, 2].max() > TOP - 0.02  # up to the worktop's lowest observed points, not the lip's bottom
    island_fp = MultiPoint(objects[InstanceId(1)].world_vertices(pose)[:, :2]).convex_hull
    assert MultiPoint(world[:, :2]).convex_hull.area > 0.99 * island_fp.area  # its whole footprint
    # with the rule off, the base is only under the mesh's lowest part (the lip) and its top the lip's bottom
    off = attach(objects, graph, shell, AttachmentConfig(amodal_top_band_m=None)).completions()[InstanceId(1)]
    assert all("seen only from above" not in c.source for c in off)
    assert max(apply(pose, c.points_asset)[:, 2].max() for c in off if c.kind.value == "base") < TOP - 0.05


def test_an_island_with_its_body_seen_gets_no_amodal_base():
    objects, graph, shell = _scene()
    island = objects[InstanceId(1)]
    rng = np.random.default_rng(1)
    front = np.c_[rng.uniform(1.1, 2.9, 2000), np.full(2000, 2.03), rng.uniform(0.4, TOP, 2000)]
    objects[InstanceId(1)] = replace(island, points=np.vstack([island.points, front]))
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert all("seen only from above" not in c.source for c in layout.completions().get(InstanceId(1), []))


def test_the_completed_island_stands_in_mujoco_with_its_cup(tmp_path):
    pytest.importorskip("mujoco")
    pytest.importorskip("pxr")
    from rescene_core.sim import simcheck_run

    objects, graph, shell = _scene()
    layout = attach(objects, graph, shell, AttachmentConfig())
    placed_list = placed_objects(list(objects.values()), layout)
    export_scene(tmp_path / "scene", placed_list, shell, graph, [], ExportConfig())
    report = json.loads((tmp_path / "scene" / "export_report.json").read_text())
    listed = [c for c in report["completions"] if c["instance"] == 1 and c["kind"] == "base"]
    assert len(listed) == 1 and "seen only from above" in listed[0]["source"]
    assert listed[0]["span_z_m"][0] == pytest.approx(0.0, abs=1e-6) and listed[0]["span_z_m"][1] > TOP - 0.02
    result = simcheck_run(tmp_path)
    assert result.summary.free == 2
    assert result.summary.stable == 2, [(o.node, o.translation, o.rotation_deg) for o in result.objects]


def test_a_generator_that_made_the_body_gets_no_base_and_the_same_block():
    # a generator that invents the island's body down to the floor (as a learned single-view model may) and
    # the slab the lift backend makes end as the same solid: the body from the mesh, or from the base
    objects, graph, shell = _scene()
    slab = objects[InstanceId(1)]
    block = trimesh.creation.box((1.8, 0.95, TOP), trimesh.transformations.translation_matrix([0, 0, -TOP / 2]))
    objects[InstanceId(1)] = replace(slab, vertices=np.asarray(block.vertices), faces=np.asarray(block.faces))
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert not [c for c in layout.completions().get(InstanceId(1), []) if c.kind.value == "base"]
    solid = objects[InstanceId(1)].world_vertices(layout.world_from_asset[InstanceId(1)])
    objects, graph, shell = _scene()
    layout = attach(objects, graph, shell, AttachmentConfig())
    pose = layout.world_from_asset[InstanceId(1)]
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    completed = np.vstack([objects[InstanceId(1)].world_vertices(pose), apply(pose, base.points_asset)])
    np.testing.assert_allclose(completed.min(axis=0), solid.min(axis=0), atol=0.02)
    np.testing.assert_allclose(completed.max(axis=0), solid.max(axis=0), atol=0.02)


def test_the_lift_backends_slab_of_an_island_seen_from_above_is_completed_to_a_block(tmp_path):
    # the weight-free backend, given a view straight down onto the worktop, makes the slab it saw; attachment
    # completes it down to the floor, and the block stands in MuJoCo
    pytest.importorskip("mujoco")
    pytest.importorskip("pxr")
    from rescene_core.assets import finish_asset
    from rescene_core.assets.lift import LiftBackend, lift_points
    from rescene_core.config import AssetConfig
    from rescene_core.geometry import sim3
    from rescene_core.sim import simcheck_run
    from tests.assets.test_assets import look_at_camera, render_view

    island = trimesh.creation.box((1.8, 0.95, TOP), trimesh.transformations.translation_matrix([2.0, 2.5, TOP / 2]))
    view = render_view(island, look_at_camera(np.array([2.0, 2.45, TOP + 1.6]), np.array([2.0, 2.5, TOP])))
    config = AssetConfig()
    asset = finish_asset(InstanceId(1), "lift", LiftBackend(config).generate(view))
    world_from_asset = sim3.compose(
        np.asarray(asset.metadata["world_from_generator"]), sim3.inverse(asset.asset_from_generator)
    )
    points = lift_points(view, config.lift.mask_erosion)
    assert np.ptp(points[:, 2]) < 0.01  # the view saw the worktop only
    slab = AssemblyObject(InstanceId(1), "kitchen island", asset.vertices, asset.faces, world_from_asset)
    slab = replace(slab, exact_shape=False, points=points)
    assert slab.world_vertices()[:, 2].min() > TOP - 0.1  # the backend made a slab, not the body
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),))
    layout = attach({InstanceId(1): slab}, graph, rect_room(), AttachmentConfig())
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    assert "seen only from above" in base.source
    world = apply(layout.world_from_asset[InstanceId(1)], base.points_asset)
    # the slab (2.2 cm above its points) comes down until its top meets the worktop where it was seen; the base
    # reaches from the floor into it: one block up to the worktop
    mesh = slab.world_vertices(layout.world_from_asset[InstanceId(1)])
    assert abs(mesh[:, 2].max() - TOP) < 0.003
    assert abs(world[:, 2].min()) < 1e-6 and world[:, 2].max() >= mesh[:, 2].min() + 0.01 - 1e-6
    assert MultiPoint(world[:, :2]).convex_hull.area > 0.9 * 1.8 * 0.95
    export_scene(tmp_path / "scene", placed_objects([slab], layout), rect_room(), graph, [], ExportConfig())
    result = simcheck_run(tmp_path)
    assert result.summary.free == 1 and result.summary.stable == 1


def test_a_stool_tucked_under_the_overhang_keeps_its_space():
    objects, graph, shell = _scene()
    objects[InstanceId(3)] = box_object(3, "bar stool", (0.35, 0.35, 0.65), placed(2.0, 2.9))  # y 2.725-3.075
    graph = SceneGraph((*graph.edges, Edge(InstanceId(3), Relation.RESTS_ON, Root.FLOOR, 0.95)))
    layout = attach(objects, graph, shell, AttachmentConfig())
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(3)], objects[InstanceId(3)].world_from_asset)
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    assert "seen only from above" in base.source
    world = apply(layout.world_from_asset[InstanceId(1)], base.points_asset)
    assert 2.70 < world[:, 1].max() <= 2.725 - 0.004  # cut back short of the stool, the rest of the block kept
    assert world[:, 1].min() < 2.06


def _wall_cabinet_seen_from_below(with_neighbour: bool = False) -> tuple[dict, SceneGraph]:
    """A wall cabinet 0.35 m deep on the wall y = 0 (1.4 to 2.0 m up, x 1.0 to 2.0) seen from below: its
    doors (y = 0.35) and its underside (y 0 to 0.35) were seen; the generated mesh is a 5 cm slab of the
    doors. With ``with_neighbour``, a second wall cabinet beside it (x 2.0 to 2.6) reaching the wall."""
    rng = np.random.default_rng(5)
    slab = box_object(1, "wall cabinet", (1.0, 0.05, 0.6), placed(1.5, 0.325, 1.4), exact_shape=False)
    doors = np.c_[rng.uniform(1.0, 2.0, 600), np.full(600, 0.35), rng.uniform(1.4, 2.0, 600)]
    underside = np.c_[rng.uniform(1.0, 2.0, 400), rng.uniform(0.0, 0.35, 400), np.full(400, 1.4)]
    objects = {InstanceId(1): replace(slab, points=np.vstack([doors, underside]))}
    edges = [Edge(InstanceId(1), Relation.MOUNTS_ON, Root.WALL, 0.9, wall_id=0)]
    if with_neighbour:
        other = box_object(2, "wall cabinet", (0.6, 0.35, 0.6), placed(2.3, 0.175, 1.4), exact_shape=False)
        pts = np.c_[rng.uniform(2.0, 2.6, 400), np.full(400, 0.35), rng.uniform(1.4, 2.0, 400)]
        objects[InstanceId(2)] = replace(other, points=pts)
        edges.append(Edge(InstanceId(2), Relation.MOUNTS_ON, Root.WALL, 0.9, wall_id=0))
    return objects, SceneGraph(tuple(edges))


def test_a_wall_cabinet_seen_from_below_is_completed_back_to_its_wall():
    from rescene_core.bench.assembly import metric_objects
    from rescene_core.evaluation.structural import structural_metrics

    objects, graph = _wall_cabinet_seen_from_below()
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    # the slab stays where its doors were seen; its body is added back to the wall
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(1)], objects[InstanceId(1)].world_from_asset)
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    world = apply(layout.world_from_asset[InstanceId(1)], base.points_asset)
    assert world[:, 1].min() == pytest.approx(0.0, abs=1e-6) and world[:, 1].max() >= 0.3
    metrics = structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())
    assert metrics["wall_contact_pass"] == 1.0
    plain = structural_metrics(objects, layout, graph, rect_room())
    assert plain["wall_contact_pass"] == 0.0  # the slab alone hangs on nothing


def test_a_wall_base_keeps_clear_of_the_cabinet_beside_it():
    objects, graph = _wall_cabinet_seen_from_below(with_neighbour=True)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    (base,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "base"]
    world = apply(layout.world_from_asset[InstanceId(1)], base.points_asset)
    neighbour = apply(layout.world_from_asset[InstanceId(2)], objects[InstanceId(2)].vertices)
    assert world[:, 0].max() <= neighbour[:, 0].min() + 1e-6
    assert world[:, 0].max() - world[:, 0].min() >= 0.5  # most of its width is kept
