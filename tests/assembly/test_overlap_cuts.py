"""Neighbours that are not related never share space: a base keeps clear of its neighbours, and two generated
meshes overlapping where both were seen nearby are cut clear of the space both fill."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Polygon

from rescene_core.assembly import attach
from rescene_core.assembly.completions import BASE_CLEARANCE, add_bases
from rescene_core.assembly.graph import build_forest
from rescene_core.assembly.objects import footprint
from rescene_core.assembly.room import room_from_shell
from rescene_core.assembly.scenes import box_object, placed, rect_room
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.trim import OVERLAP_MAX_POINT_SHARE
from rescene_core.bench.assembly import metric_objects
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.geometry.sim3 import apply
from rescene_core.records import CompletionKind, Edge, InstanceId, Relation, Root, SceneGraph

BED, STAND = InstanceId(1), InstanceId(2)


def _on_floor(*ids: InstanceId) -> SceneGraph:
    return SceneGraph(tuple(Edge(i, Relation.RESTS_ON, Root.FLOOR, 1.0) for i in ids))


def _bed_and_nightstand(stand_x: float) -> LayoutState:
    """A generated bed 2.0 x 1.6 whose mesh (the mattress, 0.3 to 0.6 m) hangs above the floor, its points
    spread over its whole footprint down to the floor, and a nightstand 0.25 m tall at ``stand_x`` under the
    mattress's corner: the meshes do not meet, the space under the mattress is the nightstand's there."""
    rng = np.random.default_rng(3)
    bed = box_object(1, "bed", (2.0, 1.6, 0.3), placed(2.0, 2.5, 0.3), exact_shape=False)
    low = np.c_[rng.uniform(1.0, 3.0, 600), rng.uniform(1.7, 3.3, 600), rng.uniform(0.0, 0.02, 600)]
    top = np.c_[rng.uniform(1.0, 3.0, 600), rng.uniform(1.7, 3.3, 600), np.full(600, 0.6)]
    bed = replace(bed, points=np.vstack([low, top]))
    stand = box_object(2, "nightstand", (0.5, 0.4, 0.25), placed(stand_x, 1.85))
    objects = {BED: bed, STAND: stand}
    room = room_from_shell(rect_room())
    state = LayoutState(objects, build_forest(_on_floor(BED, STAND), set(objects)), room, AttachmentConfig())
    state.base_wanted[BED] = "the mesh hangs above the floor"
    return state


def _base_outline(state: LayoutState, i: InstanceId) -> Polygon:
    (base,) = [c for c in state.completions[i] if c.kind is CompletionKind.BASE]
    return MultiPoint(apply(state.pose(i), base.points_asset)[:, :2]).convex_hull


def test_a_base_keeps_clear_of_the_neighbour_under_the_object():
    state = _bed_and_nightstand(stand_x=3.0)
    add_bases(state)
    base = _base_outline(state, BED)
    stand = footprint(state.vertices(STAND))
    assert base.intersection(stand).area < 1e-6  # the old base filled the nightstand's corner
    assert base.distance(stand) >= BASE_CLEARANCE - 1e-6
    # one cut past the nightstand's corner: the bed keeps more of its 3.2 m^2 than a cut along the
    # nightstand's side (x <= 2.75 keeps 2.79 m^2)
    assert base.area >= 2.85
    assert shapely.contains_xy(base, 2.0, 2.5)  # under the bed's centre


def test_a_base_with_no_neighbour_under_it_spans_the_points():
    state = _bed_and_nightstand(stand_x=3.6)  # beside the bed, not under it
    add_bases(state)
    assert _base_outline(state, BED).area >= 0.95 * 3.2


def _seen_box(instance: int, label: str, x0: float, x1: float, y0: float, y1: float, height: float, seen: tuple):
    """A generated box over [x0, x1] x [y0, y1] x [0, height], seen on its top over y in ``seen`` and on its
    face at y = seen[0] or seen[1] (the one on the box's side of the seen band)."""
    rng = np.random.default_rng(instance)
    obj = box_object(instance, label, (x1 - x0, y1 - y0, height), placed(0.5 * (x0 + x1), 0.5 * (y0 + y1)), False)
    face_y = seen[0] if abs(seen[0] - y0) < abs(seen[1] - y1) else seen[1]
    top = np.c_[rng.uniform(x0, x1, 800), rng.uniform(seen[0], seen[1], 800), np.full(800, height)]
    face = np.c_[rng.uniform(x0, x1, 800), np.full(800, face_y), rng.uniform(0.0, height, 800)]
    return replace(obj, points=np.vstack([top, face]))


def test_two_meshes_overlapping_where_neither_was_seen_are_cut_clear_and_not_moved():
    # a cabinet seen from the front (y = 1.0) to 1.4 m deep and a nightstand seen from the back (y = 1.8) to
    # 1.6: their completions share the corner x 1.9..2.0, y 1.4..1.6 that nobody saw; both were seen in the
    # 0.1 m slab along x where their footprints overlap, so no cut at the slab's far side is cheap in points
    cabinet = _seen_box(1, "cabinet", 1.0, 2.0, 1.0, 1.6, 0.8, (1.0, 1.4))
    stand = _seen_box(2, "nightstand", 1.9, 2.4, 1.4, 1.8, 0.5, (1.6, 1.8))
    objects = {InstanceId(1): cabinet, InstanceId(2): stand}
    graph = _on_floor(InstanceId(1), InstanceId(2))
    cfg = AttachmentConfig(near_wall_snap=False, depenetration_max_fit_drop=0.0)  # both held where seen
    layout = attach(objects, graph, rect_room(), cfg)
    cuts = [op for op in layout.operations if op["rule"] == "cut overlap"]
    assert len(cuts) == 1
    assert cuts[0]["points_share"] <= OVERLAP_MAX_POINT_SHARE
    assert structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())["collision_pairs"] == 0
    for i in objects:
        shift = layout.world_from_asset[i][:3, 3] - objects[i].world_from_asset[:3, 3]
        assert np.linalg.norm(shift) <= 0.031
    # the cut clears the shared corner (0.1 x 0.2 m), not a whole side of either
    assert cuts[0]["depth_m"] <= 0.2 + 1e-6
    cut = [c for c in layout.completions()[cuts[0]["instance"]] if c.kind is CompletionKind.CUT]
    assert len(cut) == 1


def _front_and_side(rng, x0: float, x1: float, side_x: float) -> np.ndarray:
    """Points on a wardrobe's front (y = 1.7, x0..x1) and on its outer side (x = side_x), 2 m tall."""
    front = np.c_[rng.uniform(x0, x1, 600), np.full(600, 1.7), rng.uniform(0.0, 2.0, 600)]
    side = np.c_[np.full(300, side_x), rng.uniform(1.7, 2.3, 300), rng.uniform(0.0, 2.0, 300)]
    return np.vstack([front, side])


def test_two_meshes_each_too_wide_into_the_other_are_both_cut_between_their_points():
    # two wardrobes side by side, each seen up to x = 2.0 and each completion 0.1 m too wide into the
    # other: neither can give up the whole overlap (each was seen in half of it), so both are cut at 2.0
    rng = np.random.default_rng(7)
    left = box_object(1, "wardrobe", (1.1, 0.6, 2.0), placed(1.55, 2.0), exact_shape=False)
    right = box_object(2, "wardrobe", (0.9, 0.6, 2.0), placed(2.35, 2.0), exact_shape=False)
    left = replace(left, points=_front_and_side(rng, 1.0, 2.0, 1.0))
    right = replace(right, points=_front_and_side(rng, 2.0, 2.8, 2.8))
    objects = {InstanceId(1): left, InstanceId(2): right}
    graph = _on_floor(InstanceId(1), InstanceId(2))
    cfg = AttachmentConfig(near_wall_snap=False, depenetration_max_fit_drop=0.0)
    layout = attach(objects, graph, rect_room(), cfg)
    cuts = [op for op in layout.operations if op["rule"] == "cut overlap"]
    assert sorted(op["instance"] for op in cuts) == [1, 2]
    assert all(op["split"] and op["points_share"] <= OVERLAP_MAX_POINT_SHARE for op in cuts)
    assert structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())["collision_pairs"] == 0
    for i in objects:
        shift = layout.world_from_asset[i][:3, 3] - objects[i].world_from_asset[:3, 3]
        assert np.linalg.norm(shift) <= 0.031


def test_an_open_mesh_counts_as_its_hull_for_the_space_both_fill():
    # the same corner as above, the nightstand's completion open at its bottom (not a closed mesh)
    cabinet = _seen_box(1, "cabinet", 1.0, 2.0, 1.0, 1.6, 0.8, (1.0, 1.4))
    stand = _seen_box(2, "nightstand", 1.9, 2.4, 1.4, 1.8, 0.5, (1.6, 1.8))
    bottom = np.flatnonzero(np.all(stand.vertices[stand.faces][:, :, 2] < 1e-9, axis=1))
    stand = replace(stand, faces=np.delete(stand.faces, bottom, axis=0))
    assert len(bottom) == 2 and not stand.mesh().is_watertight
    objects = {InstanceId(1): cabinet, InstanceId(2): stand}
    graph = _on_floor(InstanceId(1), InstanceId(2))
    cfg = AttachmentConfig(near_wall_snap=False, depenetration_max_fit_drop=0.0)
    layout = attach(objects, graph, rect_room(), cfg)
    cuts = [op for op in layout.operations if op["rule"] == "cut overlap"]
    assert len(cuts) == 1 and cuts[0]["points_share"] <= OVERLAP_MAX_POINT_SHARE
    assert structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())["collision_pairs"] == 0


def test_an_overlap_cut_never_takes_what_a_resting_object_stands_on():
    """A generated chair whose lower part reaches 15 cm into a generated table 0.4 m tall seen over its whole box, the
    chair seen only above the table's top: cutting the chair below the table's top would leave all its points
    but float it, so that cut is not made."""
    from rescene_core.assembly.collision import CollisionWorld
    from rescene_core.assembly.trim import cut_overlaps

    rng = np.random.default_rng(7)
    table = box_object(1, "table", (1.0, 1.0, 0.4), placed(2.0, 2.0), exact_shape=False)
    table = replace(table, points=rng.uniform([1.5, 1.5, 0.0], [2.5, 2.5, 0.4], (800, 3)))
    chair = box_object(2, "chair", (0.5, 0.5, 0.9), placed(2.6, 2.0), exact_shape=False)
    chair = replace(chair, points=rng.uniform([2.35, 1.75, 0.42], [2.85, 2.25, 0.9], (400, 3)))
    objects = {BED: table, STAND: chair}
    state = LayoutState(
        objects, build_forest(_on_floor(BED, STAND), set(objects)), room_from_shell(rect_room()), AttachmentConfig()
    )
    cut_overlaps(state, CollisionWorld(objects))
    for c in state.completions.get(STAND, []):
        point, normal = apply(state.pose(STAND), c.points_asset)
        assert (normal - point)[2] < 0.9  # no horizontal cut keeping only the part above


def _counter_top(rng, x0: float, x1: float, seam: tuple[float, float]) -> np.ndarray:
    """Points on a counter's top (0.9 m) and front (y = 0.6) over x0..x1, plus 7% of them bled across the seam
    with the neighbour (``seam``: x from, x to, within 2 cm of the boundary: mask bleed at the shared edge)."""
    top = np.c_[rng.uniform(x0, x1, 700), rng.uniform(0.0, 0.6, 700), np.full(700, 0.9)]
    front = np.c_[rng.uniform(x0, x1, 300), np.full(300, 0.6), rng.uniform(0.0, 0.9, 300)]
    bleed = np.c_[rng.uniform(*seam, 75), rng.uniform(0.0, 0.6, 75), np.full(75, 0.9)]
    return np.vstack([top, front, bleed])


def test_counters_in_a_row_whose_completions_overlap_are_cut_at_their_seam_not_pushed_apart():
    # three counters against the wall y = 0, each 1.0 m wide and abutting at x = 1.5 and 2.5; each generated
    # mesh is 0.08 m too wide on both sides, registered on its points: the neighbours' meshes overlap by
    # 0.16 m. Pushed apart, the outer ones would leave their points by up to 0.16 m; cut at the seam, no
    # counter moves
    rng = np.random.default_rng(11)
    spans = {1: (0.5, 1.5), 2: (1.5, 2.5), 3: (2.5, 3.5)}
    objects = {}
    for i, (x0, x1) in spans.items():
        obj = box_object(i, "kitchen counter", (1.16, 0.6, 0.9), placed(0.5 * (x0 + x1), 0.3), exact_shape=False)
        seams = [(x0 - 0.02, x0) if x0 > 0.5 else None, (x1, x1 + 0.02) if x1 < 3.5 else None]
        pts = _counter_top(rng, x0, x1, next(s for s in seams if s is not None))
        objects[InstanceId(i)] = replace(obj, points=pts)
    graph = _on_floor(*objects)
    layout = attach(objects, graph, rect_room(), AttachmentConfig())
    cuts = [op for op in layout.operations if op["rule"] == "cut overlap"]
    assert {op["stage"] for op in cuts} == {"registered overlap cuts"}
    assert structural_metrics(metric_objects(objects, layout), layout, graph, rect_room())["collision_pairs"] == 0
    for i in objects:
        shift = layout.world_from_asset[i][:3, 3] - objects[i].world_from_asset[:3, 3]
        assert np.linalg.norm(shift[:2]) <= 0.01
