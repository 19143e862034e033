"""Observed points as evidence: support planes a generated parent's mesh lacks, and corrections refused
when they would move a generated object away from where the capture saw it."""

from dataclasses import replace

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.bench.assembly import metric_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
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


def test_no_board_without_a_band_of_points():
    objects, graph, shell = _shelf_scene(_bookshelf_points(np.random.default_rng(0), []))
    layout = attach(objects, graph, shell, AttachmentConfig())
    assert not [op for op in layout.operations if op["rule"] == "support plane"]
    skip = [op for op in layout.operations if op["instance"] == 2 and op["rule"] == "skip"]
    assert skip and "inner shelf" in skip[0]["reason"]
    # the child keeps its registered pose, moved only by the repairs that carry its parent
    parent_move = layout.world_from_asset[InstanceId(1)] @ np.linalg.inv(objects[InstanceId(1)].world_from_asset)
    np.testing.assert_allclose(
        layout.world_from_asset[InstanceId(2)], parent_move @ objects[InstanceId(2)].world_from_asset, atol=1e-9
    )
    assert abs(layout.world_from_asset[InstanceId(2)][2, 3] - 0.905) < 1e-9


def test_floor_snap_refused_when_it_leaves_the_seen_points():
    # a generated table top (the mesh lacks the legs) registered where it was seen, 0.72 m up
    rng = np.random.default_rng(1)
    top = np.c_[rng.uniform(1.0, 2.0, 500), rng.uniform(2.0, 2.8, 500), rng.uniform(0.72, 0.76, 500)]
    table = replace(box_object(1, "table", (1.0, 0.8, 0.05), placed(1.5, 2.4, 0.72), exact_shape=False), points=top)
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.95),))
    layout = attach({InstanceId(1): table}, graph, rect_room(), AttachmentConfig())
    np.testing.assert_allclose(layout.world_from_asset[InstanceId(1)], table.world_from_asset, atol=1e-9)
    skip = [op for op in layout.operations if op["instance"] == 1 and op["stage"] == "floor snap"]
    assert skip and "observed points" in skip[0]["reason"]
    # the same slab whose points were seen on the floor is snapped down
    low = replace(table, points=top - [0.0, 0.0, 0.72])
    layout = attach({InstanceId(1): low}, graph, rect_room(), AttachmentConfig())
    assert low.world_vertices(layout.world_from_asset[InstanceId(1)])[:, 2].min() < 0.02
