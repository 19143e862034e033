"""Observed points as evidence: support planes a generated parent's mesh lacks, and corrections refused
when they would move a generated object away from where the capture saw it."""

from dataclasses import replace

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.bench.assembly import metric_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph


def _bookshelf_points(rng, board_heights):
    """Points of a 1.0 x 0.4 x 1.8 m bookshelf at (2, 4.5): side panels at every height, and a band of
    points along each board's front edge and top."""
    sides = np.c_[rng.choice([1.5, 2.5], 3000), rng.uniform(4.3, 4.7, 3000), rng.uniform(0.0, 1.8, 3000)]
    boards = [
        np.c_[rng.uniform(1.5, 2.5, 600), rng.uniform(4.3, 4.7, 600), h - rng.uniform(0.0, 0.02, 600)]
        for h in board_heights
    ]
    return np.vstack([sides, *boards])


def _shelf_scene(points):
    shelf = box_object(1, "bookshelf", (1.0, 0.4, 1.8), placed(2.0, 4.5), exact_shape=False)
    shelf = replace(shelf, points=points)
    books = box_object(2, "book stack", (0.3, 0.25, 0.2), placed(2.0, 4.5, 0.905), exact_shape=False)
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.95),
        )
    )
    return {InstanceId(1): shelf, InstanceId(2): books}, graph, rect_room()


def test_shelf_board_from_the_parents_points():
    objects, graph, shell = _shelf_scene(_bookshelf_points(np.random.default_rng(0), [0.45, 0.9, 1.35]))
    layout = attach(objects, graph, shell, AttachmentConfig())
    planes = [op for op in layout.operations if op["rule"] == "support plane"]
    assert len(planes) == 1 and planes[0]["instance"] == 1 and planes[0]["children"] == [2]
    assert abs(planes[0]["height_m"] - 0.9) < 0.02
    bottom = objects[InstanceId(2)].world_vertices(layout.world_from_asset[InstanceId(2)])[:, 2].min()
    assert abs(bottom - planes[0]["height_m"]) < 0.005  # on the board, not lifted 0.9 m onto the top
    plain = structural_metrics(objects, layout, graph, shell)
    boarded = structural_metrics(metric_objects(objects, layout), layout, graph, shell)
    assert plain["support_contact_pass"] == 0.0 and boarded["support_contact_pass"] == 1.0


def test_without_a_band_of_points_the_board_is_at_the_childs_registered_bottom():
    # the parent's points show no board (the books hide it): the child inside the solid completion can only
    # stand on an inner shelf at its own registered bottom
    objects, graph, shell = _shelf_scene(_bookshelf_points(np.random.default_rng(0), []))
    layout = attach(objects, graph, shell, AttachmentConfig())
    planes = [op for op in layout.operations if op["rule"] == "support plane"]
    assert len(planes) == 1 and "child's registered bottom" in planes[0]["source"]
    assert abs(planes[0]["height_m"] - 0.905) < 0.005
    # the child keeps its registered height (on the board), not lifted 0.9 m onto the top
    assert abs(layout.world_from_asset[InstanceId(2)][2, 3] - 0.905) < 1e-9
    boarded = structural_metrics(metric_objects(objects, layout), layout, graph, shell)
    assert boarded["support_contact_pass"] == 1.0


def test_no_inner_board_for_a_child_outside_its_parent():
    # registered beside the shelf, 0.9 m up: nothing inside the parent can carry it
    objects, graph, shell = _shelf_scene(_bookshelf_points(np.random.default_rng(0), []))
    objects[InstanceId(2)] = box_object(2, "book stack", (0.3, 0.25, 0.2), placed(3.2, 4.5, 0.905), exact_shape=False)
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert not [op for op in layout.operations if op["rule"] == "support plane"]
    skip = [op for op in layout.operations if op["instance"] == 2 and op["rule"] == "skip"]
    assert skip and "inner shelf" in skip[0]["reason"]


def test_a_table_top_without_legs_keeps_its_height_and_gets_a_base():
    # a generated table top (the mesh lacks the legs) registered where it was seen, 0.72 m up
    rng = np.random.default_rng(1)
    top = np.c_[rng.uniform(1.0, 2.0, 500), rng.uniform(2.0, 2.8, 500), rng.uniform(0.72, 0.76, 500)]
    table = replace(box_object(1, "table", (1.0, 0.8, 0.05), placed(1.5, 2.4, 0.72), exact_shape=False), points=top)
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),))
    layout = attach({InstanceId(1): table}, graph, rect_room(), AttachmentConfig())
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(1)], table.world_from_asset, atol=1e-9)
    snap = [op for op in layout.operations if op["instance"] == 1 and op["stage"] == "floor snap"]
    assert snap and "observed points" in snap[0]["reason"] and snap[0]["snap_taken"] == 0.0
    bases = layout.completions()[InstanceId(1)]
    assert [c.kind.value for c in bases] == ["base"]
    world = table.world_vertices(layout.world_from_asset[InstanceId(1)])
    base = bases[0].points_asset @ np.eye(3)  # asset frame = world here (placed without rotation or scale)
    base = base + table.world_from_asset[:3, 3]
    assert abs(base[:, 2].min()) < 1e-9 and abs(base[:, 2].max() - (world[:, 2].min() + 0.01)) < 1e-6
    plain = structural_metrics({InstanceId(1): table}, layout, graph, rect_room())
    completed = structural_metrics(metric_objects({InstanceId(1): table}, layout), layout, graph, rect_room())
    assert plain["floor_contact_pass"] == 0.0 and completed["floor_contact_pass"] == 1.0
    # an edge too weak to trust gets no base
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.2),))
    assert not attach({InstanceId(1): table}, graph, rect_room(), AttachmentConfig()).completions()


def test_a_weak_floor_edge_is_trusted_only_when_nothing_lies_beneath():
    # a nightstand seen 0.2 m up (its lower part hidden), its floor edge fused at 0.45
    rng = np.random.default_rng(3)
    pts = np.c_[rng.uniform(1.3, 1.7, 400), rng.uniform(2.3, 2.7, 400), rng.uniform(0.2, 0.6, 400)]
    stand = replace(box_object(1, "nightstand", (0.4, 0.4, 0.4), placed(1.5, 2.5, 0.2), exact_shape=False), points=pts)
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.45),))
    layout = attach({InstanceId(1): stand}, graph, rect_room(), AttachmentConfig())
    assert [op["rule"] for op in layout.operations if op["instance"] == 1][0] == "trust floor edge"
    completed = structural_metrics(metric_objects({InstanceId(1): stand}, layout), layout, graph, rect_room())
    assert completed["floor_contact_pass"] == 1.0
    # a crate under it (no edge between them): the floor is not all there is, the weak edge stays weak
    crate = box_object(2, "box", (0.5, 0.5, 0.18), placed(1.5, 2.5), exact_shape=False)
    graph = SceneGraph((*graph.edges, Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 1.0)))
    layout = attach({InstanceId(1): stand, InstanceId(2): crate}, graph, rect_room(), AttachmentConfig())
    assert not [op for op in layout.operations if op["rule"] == "trust floor edge"]
    assert InstanceId(1) not in layout.completions()
    # and the threshold can switch the rule off
    cfg = AttachmentConfig(floor_trust_min_confidence=None)
    layout = attach({InstanceId(1): stand}, SceneGraph(graph.edges[:1]), rect_room(), cfg)
    assert not [op for op in layout.operations if op["rule"] == "trust floor edge"]


def test_a_short_mesh_registered_too_high_comes_down_to_its_points_top():
    # a floor lamp 1.6 m tall seen whole; its generated mesh is 1.0 m tall, registered 0.3 m too high
    rng = np.random.default_rng(2)
    pole = np.c_[rng.normal(2.0, 0.02, 800), rng.normal(2.0, 0.02, 800), rng.uniform(0.0, 1.2, 800)]
    shade = np.c_[rng.uniform(1.8, 2.2, 800), rng.uniform(1.8, 2.2, 800), rng.uniform(1.2, 1.6, 800)]
    lamp = box_object(1, "floor lamp", (0.4, 0.4, 1.0), placed(2.0, 2.0, 0.9), exact_shape=False)
    lamp = replace(lamp, points=np.vstack([pole, shade]))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),))
    layout = attach({InstanceId(1): lamp}, graph, rect_room(), AttachmentConfig())
    world = lamp.world_vertices(layout.world_from_asset[InstanceId(1)])
    assert abs(world[:, 2].max() - 1.6) < 0.05  # its top on the top of its points, not 0.3 m above
    (base,) = layout.completions()[InstanceId(1)]
    base_world = base.points_asset + layout.world_from_asset[InstanceId(1)][:3, 3]
    assert abs(base_world[:, 2].min()) < 1e-9
    assert np.ptp(base_world[:, 0]) < 0.2  # under the pole the points show, not the whole shade
    completed = structural_metrics(metric_objects({InstanceId(1): lamp}, layout), layout, graph, rect_room())
    assert completed["floor_contact_pass"] == 1.0


def test_a_slab_seen_on_the_floor_is_snapped_down():
    rng = np.random.default_rng(1)
    top = np.c_[rng.uniform(1.0, 2.0, 500), rng.uniform(2.0, 2.8, 500), rng.uniform(0.72, 0.76, 500)]
    table = replace(box_object(1, "table", (1.0, 0.8, 0.05), placed(1.5, 2.4, 0.72), exact_shape=False), points=top)
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),))
    # the same slab whose points were seen on the floor is snapped down
    low = replace(table, points=top - [0.0, 0.0, 0.72])
    layout = attach({InstanceId(1): low}, graph, rect_room(), AttachmentConfig())
    assert low.world_vertices(layout.world_from_asset[InstanceId(1)])[:, 2].min() < 0.02


def test_a_push_is_bounded_by_the_points_on_the_movers_surface():
    # a chair tucked 0.25 m under a generated table whose completion filled the space between its legs
    rng = np.random.default_rng(4)
    front = np.c_[rng.uniform(1.3, 1.7, 600), np.full(600, 1.5) + rng.normal(0, 0.003, 600), rng.uniform(0, 0.9, 600)]
    chair = replace(box_object(1, "chair", (0.4, 0.45, 0.9), placed(1.5, 1.725), exact_shape=False), points=front)
    table_top = np.c_[rng.uniform(1.0, 2.0, 600), rng.uniform(1.6, 2.4, 600), rng.uniform(0.74, 0.75, 600)]
    table = replace(box_object(2, "table", (1.0, 0.8, 0.75), placed(1.5, 2.0), exact_shape=False), points=table_top)
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 1.0),
        )
    )
    objects = {InstanceId(1): chair, InstanceId(2): table}
    cfg = AttachmentConfig(near_wall_snap=False, dual_attachment=False)
    bounded = attach(objects, graph, rect_room(), cfg)
    moved = np.linalg.norm(bounded.world_from_asset[InstanceId(1)][:2, 3] - chair.world_from_asset[:2, 3])
    assert moved < 0.05  # held by the points on its front: at most the surface margin
    held = [op for op in bounded.operations if op["rule"] == "held by its points"]
    assert held
    free = attach(objects, graph, rect_room(), cfg.model_copy(update={"depenetration_max_fit_drop": None}))
    gone = np.linalg.norm(free.world_from_asset[InstanceId(1)][:2, 3] - chair.world_from_asset[:2, 3])
    assert gone > 0.1  # unbounded, the pushes carry it away from where it was seen


def _stepped_parent():
    """A generated 'table' of 0.1 x 0.1 m pillars 2 cm apart whose tops step by 4 cm (a marching-cubes surface, no two neighbours level):
    no upward face is large enough to carry a 0.3 x 0.25 m book stack."""
    import trimesh

    from rescene_core.assembly.objects import AssemblyObject

    pillars = []
    for k, (x, y) in enumerate((x, y) for x in np.arange(0, 0.6, 0.12) for y in np.arange(0, 0.48, 0.12)):
        pillar = trimesh.creation.box(extents=(0.10, 0.10, 0.70 + 0.04 * (k % 3)))
        pillar.apply_translation([1.76 + x, 2.26 + y, (0.70 + 0.04 * (k % 3)) / 2])
        pillars.append(pillar)
    mesh = trimesh.util.concatenate(pillars)
    return AssemblyObject(InstanceId(1), "table", mesh.vertices, mesh.faces, np.eye(4), exact_shape=False)


def test_a_stepped_generated_top_is_no_face_and_the_child_keeps_its_height_on_a_plane():
    parent = _stepped_parent()
    books = box_object(2, "book stack", (0.3, 0.25, 0.2), placed(2.05, 2.5, 0.78), exact_shape=False)
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 1.0),
        )
    )
    objects = {InstanceId(1): parent, InstanceId(2): books}
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    (plane,) = [c for c in layout.completions()[InstanceId(1)] if c.kind.value == "support plane"]
    assert "registered bottom" in plane.source
    assert abs(layout.world_from_asset[InstanceId(2)][2, 3] - 0.78) < 1e-6  # not dropped onto a lower step
    m = structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())
    assert m["support_contact_pass"] == 1.0
    # registered 0.3 m above the top: no plane in mid-air
    objects[InstanceId(2)] = box_object(2, "book stack", (0.3, 0.25, 0.2), placed(2.05, 2.5, 1.08), exact_shape=False)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert not [c for c in layout.completions().get(InstanceId(1), []) if c.kind.value == "support plane"]


def test_a_mesh_touching_the_floor_only_at_an_edge_gets_a_base_under_it():
    # a generated bed whose completion came out as a wedge: it touches the floor along one edge only
    import trimesh

    from rescene_core.assembly.objects import AssemblyObject, footprint

    wedge = trimesh.convex.convex_hull(
        np.array([[x, y, z] for x in (1.0, 3.0) for y in (2.0, 3.6) for z in (0.0, 0.6)])
        + np.array([[0, 0, 0]] * 4 + [[0, 0, 0.3], [0, 0, 0.3], [0, 0, 0.3], [0, 0, 0.3]]) * np.array([1, 1, 1])
    )
    verts = np.asarray(wedge.vertices).copy()
    verts[verts[:, 0] > 2.0, 2] += 0.3  # the far half floats: only the x = 1 edge rests on the floor
    bed = AssemblyObject(InstanceId(1), "bed", verts, np.asarray(wedge.faces), np.eye(4), exact_shape=False)
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    layout = attach({InstanceId(1): bed}, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    (base,) = layout.completions()[InstanceId(1)]
    assert base.kind.value == "base" and "only at an edge" in base.source
    world = apply(layout.world_from_asset[InstanceId(1)], base.points_asset)
    assert abs(world[:, 2].min()) < 1e-9
    placed_bed = footprint(bed.world_vertices(layout.world_from_asset[InstanceId(1)]))
    assert footprint(world).buffer(1e-6).contains(placed_bed.centroid)
    # an exact shape standing on its whole underside gets none
    box = box_object(2, "bed", (2.0, 1.6, 0.6), placed(2.0, 2.8), exact_shape=False)
    graph = SceneGraph((Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    assert not attach({InstanceId(2): box}, graph, rect_room(), AttachmentConfig(near_wall_snap=False)).completions()


def test_a_base_under_part_of_an_object_counts_and_one_under_its_lower_part_is_added_when_it_tips():
    # a generated cabinet seen 0.2 m up, its points reaching the floor only along its front (x < 1.85):
    # the base from those points carries its front edge, its centre (x = 2.0) is far behind it
    from rescene_core.assembly.objects import footprint

    rng = np.random.default_rng(4)
    body = np.c_[rng.uniform(1.75, 2.25, 800), rng.uniform(1.9, 3.1, 800), rng.uniform(0.3, 0.8, 800)]
    front = np.c_[rng.uniform(1.75, 1.85, 200), rng.uniform(1.9, 3.1, 200), rng.uniform(0.0, 0.2, 200)]
    cabinet = box_object(1, "cabinet", (0.5, 1.2, 0.6), placed(2.0, 2.5, 0.2), exact_shape=False)
    cabinet = replace(cabinet, points=np.vstack([body, front]))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    layout = attach({InstanceId(1): cabinet}, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    bases = layout.completions()[InstanceId(1)]
    assert [c.kind.value for c in bases] == ["base", "base"]
    assert "observed points" in bases[0].source and "only at an edge" in bases[1].source
    pose = layout.world_from_asset[InstanceId(1)]
    first, second = (apply(pose, c.points_asset) for c in bases)
    centre = footprint(cabinet.world_vertices(pose)).centroid
    assert not footprint(first).contains(centre)
    assert abs(second[:, 2].min()) < 1e-9 and footprint(second).buffer(1e-6).contains(centre)
