"""Where a generated support's top was seen: a child stands on the top its parent's points show, a floor snap
does not lower the seen top of a mesh too short for it."""

from dataclasses import replace

import numpy as np

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.config import AttachmentConfig
from rescene_core.geometry.sim3 import apply
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

ISLAND = InstanceId(1)
CUP = InstanceId(2)


def _island_points(rng, top: float) -> np.ndarray:
    """Points of a 1.2 x 0.8 m island at (2, 2.5) seen from above: its worktop at ``top`` (1 mm depth noise)
    and the upper 4 cm of its front."""
    worktop = np.c_[rng.uniform(1.4, 2.6, 1500), rng.uniform(2.1, 2.9, 1500), top + rng.normal(0.0, 0.001, 1500)]
    front = np.c_[rng.uniform(1.4, 2.6, 300), np.full(300, 2.1), rng.uniform(top - 0.04, top, 300)]
    return np.vstack([worktop, front])


def _cup_points(rng, bottom: float) -> np.ndarray:
    """A cup 8 cm across and 10 cm tall at (2.1, 2.5) standing at ``bottom``, seen down to it."""
    angle = rng.uniform(0.0, 2.0 * np.pi, 400)
    return np.c_[2.1 + 0.04 * np.cos(angle), 2.5 + 0.04 * np.sin(angle), rng.uniform(bottom, bottom + 0.1, 400)]


def _kitchen(mesh_height: float, seen_top: float, island_z: float = 0.0):
    rng = np.random.default_rng(7)
    island = box_object(1, "kitchen island", (1.2, 0.8, mesh_height), placed(2.0, 2.5, island_z), exact_shape=False)
    island = replace(island, points=_island_points(rng, seen_top))
    cup = box_object(2, "coffee cup", (0.08, 0.08, 0.1), placed(2.1, 2.5, seen_top), exact_shape=False)
    cup = replace(cup, points=_cup_points(rng, seen_top))
    graph = SceneGraph(
        (
            Edge(ISLAND, Relation.RESTS_ON, Root.FLOOR, 1.0),
            Edge(CUP, Relation.RESTS_ON, ISLAND, 0.9),
        )
    )
    return {ISLAND: island, CUP: cup}, graph


def _cup_bottom(objects, layout) -> float:
    return float(objects[CUP].world_vertices(layout.world_from_asset[CUP])[:, 2].min())


def test_a_child_stands_on_the_top_seen_around_it_not_on_a_generated_top_a_centimetre_higher():
    # the island's completion is 1 cm taller than its worktop seen at 0.90 m: within the 2 cm a generated face
    # was trusted, the cup was lifted 1 cm onto it
    objects, graph = _kitchen(mesh_height=0.91, seen_top=0.90)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert abs(_cup_bottom(objects, layout) - 0.90) < 0.002
    support = [op for op in layout.operations if op["instance"] == 2 and op["stage"] == "object support"]
    assert support and support[-1]["support_plane"] == "the parent's observed top around the child"
    # a face within 2.5 mm of the seen top is the top: the cup stands on the mesh itself
    objects, graph = _kitchen(mesh_height=0.902, seen_top=0.90)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert abs(_cup_bottom(objects, layout) - 0.902) < 1e-6
    assert "support_plane" not in [op for op in layout.operations if op["instance"] == 2][0]


def test_a_floor_snap_keeps_the_seen_top_of_a_mesh_too_short_and_a_base_fills_the_gap():
    # the island's completion is 1.6 cm short of the floor, registered on the worktop seen at 0.90 m: the full
    # snap took its top, and the cup with it, 1.6 cm below where the capture saw them
    objects, graph = _kitchen(mesh_height=0.884, seen_top=0.90, island_z=0.016)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    top = objects[ISLAND].world_vertices(layout.world_from_asset[ISLAND])[:, 2].max()
    assert 0.898 <= top <= 0.90 + 1e-9
    snap = [op for op in layout.operations if op["instance"] == 1 and op["stage"] == "floor snap"][0]
    assert snap["snap_taken"] < 0.2 and "top its observed points show" in snap["reason"]
    (base,) = layout.completions()[ISLAND]
    assert (
        base.kind.value == "base" and abs(apply(layout.world_from_asset[ISLAND], base.points_asset)[:, 2].min()) < 1e-9
    )
    assert abs(_cup_bottom(objects, layout) - 0.90) < 0.002
    # a mesh of the island's full height registered 1.6 cm high is snapped down whole: its top meets the seen top
    objects, graph = _kitchen(mesh_height=0.90, seen_top=0.90, island_z=0.016)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert abs(objects[ISLAND].world_vertices(layout.world_from_asset[ISLAND])[:, 2].min()) < 1e-9
    assert ISLAND not in layout.completions()


def test_a_child_is_not_re_seated_on_a_parent_that_a_repair_took_far_from_its_points():
    from rescene_core.assembly.graph import build_forest
    from rescene_core.assembly.refine import reseat_children
    from rescene_core.assembly.room import room_from_shell
    from rescene_core.assembly.state import LayoutState
    from rescene_core.assembly.transforms import translation

    objects, graph = _kitchen(mesh_height=0.90, seen_top=0.90)
    # the cup's mask bled over the worktop: most of its points lie away from it, so no move of its mesh leaves
    # enough of them behind for the evidence to refuse it (``evidence.evidence_refuses``)
    rng = np.random.default_rng(8)
    bleed = np.c_[rng.uniform(1.4, 2.6, 800), rng.uniform(2.1, 2.9, 800), np.full(800, 0.90)]
    objects[CUP] = replace(objects[CUP], points=np.vstack([objects[CUP].points, bleed]))
    cfg = AttachmentConfig(near_wall_snap=False)
    state = LayoutState(objects, build_forest(graph, set(objects)), room_from_shell(rect_room()), cfg)
    # a repair took the island 0.2 m along y: the cup's registered centre is still over its top, it goes back there
    state.move(ISLAND, translation([0.0, 0.2, 0.0]), "test", "repair", bounded=False)
    reseat_children(state)
    np.testing.assert_allclose(state.pose(CUP)[:3, 3], objects[CUP].world_from_asset[:3, 3], atol=1e-9)
    # 0.9 m: its nearest edge lies 0.5 m from where the cup was seen; it keeps its registered pose
    state.move(ISLAND, translation([0.0, 0.7, 0.0]), "test", "repair", bounded=False)
    reseat_children(state)
    np.testing.assert_allclose(state.pose(CUP), objects[CUP].world_from_asset, atol=1e-9)
    skip = [op for op in state.operations if op.instance == CUP and op.rule == "skip"]
    assert skip and "from where its points were seen" in skip[-1].details["reason"]


def test_the_front_of_a_support_below_its_seen_top_does_not_carry_a_child_registered_low():
    # a plant registered 4 cm low against the island's front (its mesh not cut): the island's points within 5 cm
    # of it at its registered bottom are the front's, the worktop above them is denser
    objects, graph = _kitchen(mesh_height=0.91, seen_top=0.90)
    rng = np.random.default_rng(9)
    plant = box_object(2, "potted plant", (0.2, 0.2, 0.3), placed(2.0, 2.14, 0.86), exact_shape=False)
    angle = rng.uniform(0.0, 2.0 * np.pi, 400)
    pot = np.c_[2.0 + 0.1 * np.cos(angle), 2.14 + 0.1 * np.sin(angle), rng.uniform(0.90, 1.16, 400)]
    objects[CUP] = replace(plant, points=pot)
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False, trim_completions=False))
    support = [op for op in layout.operations if op["instance"] == 2 and op["stage"] == "object support"][-1]
    assert "around the child" not in support.get("support_plane", "")
    assert _cup_bottom(objects, layout) > 0.895


def _voxel_layered_island(rng, top: float) -> np.ndarray:
    """The island's worktop at ``top`` as fused by voxel means where it straddles a voxel boundary 4 mm above
    it: in every 1.5 cm column the bulk of the depth samples averages to the top, and in two columns of three
    the noise tail beyond the boundary to a layer 7 mm higher; with the upper 4 cm of its front."""
    x, y = np.meshgrid(np.arange(1.41, 2.6, 0.015), np.arange(2.11, 2.9, 0.015))
    xy = np.c_[x.ravel(), y.ravel()]
    bulk = np.c_[xy, top + rng.normal(0.0, 0.0005, len(xy))]
    tail = xy[rng.random(len(xy)) < 2.0 / 3.0]
    tail = np.c_[tail, top + 0.007 + rng.normal(0.0, 0.0005, len(tail))]
    front = np.c_[rng.uniform(1.4, 2.6, 300), np.full(300, 2.1), rng.uniform(top - 0.04, top, 300)]
    return np.vstack([bulk, tail, front])


def test_the_top_seen_around_a_child_is_its_supports_surface_not_a_voxel_layer_or_the_childs_bleed():
    from rescene_core.assembly.compile_support import top_seen_around
    from rescene_core.assembly.room import room_from_shell

    rng = np.random.default_rng(12)
    # the island's completion 1 cm taller than its worktop seen at 0.90 m: the cup stands on the seen top
    objects, graph = _kitchen(mesh_height=0.91, seen_top=0.90)
    # the cup's side, lost to the island's mask over its footprint (its mesh 1 cm wider than the cup), up to
    # the top of the band the surface is read in
    angle = rng.uniform(0.0, 2.0 * np.pi, 300)
    bleed = np.c_[2.1 + 0.035 * np.cos(angle), 2.5 + 0.035 * np.sin(angle), rng.uniform(0.90, 0.915, 300)]
    objects[ISLAND] = replace(objects[ISLAND], points=np.vstack([_voxel_layered_island(rng, 0.90), bleed]))
    top = top_seen_around(objects[ISLAND], objects[CUP], room_from_shell(rect_room()))
    # the band's upper quartile read the tail's layer and the bleed: 6-7 mm high
    assert top is not None and abs(top - 0.90) < 0.001
    layout = attach(objects, graph, rect_room(), AttachmentConfig(near_wall_snap=False))
    assert abs(_cup_bottom(objects, layout) - 0.90) < 0.0015
