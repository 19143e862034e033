"""Completion records: layout round trip, surfaces for contacts and solids for colliders."""

from __future__ import annotations

import numpy as np
import trimesh

from rescene_core.geometry.completion import completed_mesh, completion_solid, completion_surface, cut_mesh
from rescene_core.geometry.sim3 import apply, sim3_from_parts
from rescene_core.records import Completion, CompletionKind, InstanceId, Layout, Operation

SQUARE = np.array([[0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]], np.float64)


def test_layout_reads_support_planes_and_bases_from_its_operations():
    cube = np.array([[x, y, z] for x in (0, 0.2) for y in (0, 0.2) for z in (0, 0.3)])
    ops = (
        Operation(3, "all", "object support", "support plane", {"polygon_asset": SQUARE, "source": "points"}),
        Operation(3, "all", "floor snap", "floor snap"),
        Operation(5, "all", "completions", "base", {"points_asset": cube, "source": "legs seen"}),
    )
    layout = Layout.from_json(Layout({}, ops).to_json())
    got = layout.completions()
    assert sorted(got) == [3, 5]
    assert got[InstanceId(3)][0].kind is CompletionKind.SUPPORT_PLANE
    assert got[InstanceId(5)][0].kind is CompletionKind.BASE and got[InstanceId(5)][0].source == "legs seen"
    again = Completion.from_json(got[InstanceId(5)][0].to_json())
    np.testing.assert_array_equal(again.points_asset, cube)


def test_a_base_is_a_closed_outward_hull_and_a_board_is_two_sided():
    cube = np.array([[x, y, z] for x in (0, 0.2) for y in (0, 0.2) for z in (0, 0.3)]) + 0.05
    v, f = completion_surface(Completion(InstanceId(1), CompletionKind.BASE, cube))
    mesh = trimesh.Trimesh(v, f, process=True)
    assert mesh.is_watertight and mesh.volume > 0
    np.testing.assert_allclose(mesh.volume, 0.2 * 0.2 * 0.3, rtol=1e-9)
    v, f = completion_surface(Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, SQUARE))
    assert len(f) == 4  # two triangles, each in both orientations
    verts, faces = completed_mesh(
        np.zeros((3, 3)), np.array([[0, 1, 2]]), [Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, SQUARE)]
    )
    assert len(verts) == 7 and faces.max() == 6


def test_a_board_solid_is_its_thickness_below_the_plane_in_the_world():
    # asset frame scaled by 2 and turned upside down: down in the world is +z in the asset
    pose = sim3_from_parts(2.0, np.diag([1.0, -1.0, -1.0]), np.array([0.3, 0.0, 1.0]))
    solid = completion_solid(Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, SQUARE), pose, 0.02)
    world = apply(pose, solid)
    assert solid.shape == (8, 3)
    np.testing.assert_allclose(np.ptp(world[:, 2]), 0.02, atol=1e-12)
    assert world[4:, 2].max() < world[:4, 2].min()


def test_a_cut_keeps_the_side_its_normal_points_to_and_stays_closed():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    cut = Completion(InstanceId(1), CompletionKind.CUT, np.array([[0.0, 0.0, -0.2], [0.0, 0.0, 0.8]]))
    v, f = completed_mesh(box.vertices, box.faces, [cut])
    kept = trimesh.Trimesh(v, f)
    assert kept.is_watertight
    np.testing.assert_allclose(kept.volume, 0.7, rtol=1e-9)
    np.testing.assert_allclose(v[:, 2].min(), -0.2, atol=1e-12)
    ops = (Operation(1, "all", "completions", "cut", {"points_asset": cut.points_asset, "source": "wall"}),)
    assert Layout({}, ops).completions()[InstanceId(1)][0].kind is CompletionKind.CUT


def test_a_cut_at_the_mesh_own_side_face_keeps_the_mesh_inside_its_bounds():
    # the side face's vertices lie on the plane to within rounding, some just past trimesh's 1e-8 tolerance
    rng = np.random.default_rng(0)
    box = trimesh.creation.box(extents=(1.0, 0.7, 0.9)).subdivide().subdivide().subdivide()
    box.merge_vertices()
    vertices = np.array(box.vertices)
    side = np.isclose(vertices[:, 0], -0.5)
    vertices[side, 0] += rng.uniform(-2e-8, 2e-8, side.sum())
    cut = Completion(InstanceId(1), CompletionKind.CUT, np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]]), "overlap")
    v, f = cut_mesh(vertices, np.asarray(box.faces), [cut])
    np.testing.assert_array_less(v.max(axis=0), vertices.max(axis=0) + 1e-5)
    np.testing.assert_array_less(vertices.min(axis=0) - 1e-5, v.min(axis=0))
    assert trimesh.Trimesh(v, f).is_watertight
