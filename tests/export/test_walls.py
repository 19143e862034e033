"""Free objects' pieces cut at the walls they graze (rescene_core/colliders/walls.py): on the geometry, in the
export report, and with the physics check."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.colliders.pieces import placement
from rescene_core.colliders.walls import MAX_DEPTH, clear_of_walls, trimmed_walls
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane
from tests.fixtures import CORNER_SHELL

pytest.importorskip("mujoco")


def lamp(into: float) -> ExportObject:
    """A 'floor lamp' 1.6 m tall, its 20 cm post under a 40 cm shade, in the corner, ``into`` m through both
    walls."""
    post = trimesh.creation.box(bounds=[[0.1, 0.1, 0.0], [0.3, 0.3, 1.0]])
    shade = trimesh.creation.box(bounds=[[0.0, 0.0, 1.0], [0.4, 0.4, 1.6]])
    mesh = trimesh.util.concatenate([post, shade])
    at = [-2.0 - into, -2.0 - into, 0.0]
    return ExportObject(1, "floor lamp", mesh.vertices, mesh.faces, sim3.sim3_from_parts(1.0, np.eye(3), at))


def test_pieces_grazing_a_wall_are_cut_at_its_plane_and_deep_ones_are_left():
    obj = lamp(0.008)
    box = trimesh.creation.box(bounds=[[0.0, 0.0, 1.0], [0.4, 0.4, 1.6]])
    pieces = [(np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64))]
    place = placement(obj)
    cut, depth = clear_of_walls(place, pieces, trimmed_walls(CORNER_SHELL))
    world = place.world(cut[0][0])
    assert world[:, :2].min() == pytest.approx(-2.0, abs=1e-9)  # on both planes, not behind them
    assert depth == {"0": pytest.approx(0.008), "1": pytest.approx(0.008)}
    deep = lamp(MAX_DEPTH + 0.03)
    kept, none = clear_of_walls(placement(deep), pieces, trimmed_walls(CORNER_SHELL))
    assert none == {} and kept[0] is pieces[0]
    # a crossing of a millimetre is cut as well: a position-based engine would throw it off at t = 0
    graze = lamp(0.001)
    cut, depth = clear_of_walls(placement(graze), pieces, trimmed_walls(CORNER_SHELL))
    assert depth == {"0": pytest.approx(0.001), "1": pytest.approx(0.001)}
    assert placement(graze).world(cut[0][0])[:, :2].min() == pytest.approx(-2.0, abs=1e-9)


def test_a_piece_the_export_added_is_cut_at_the_wall_whatever_its_depth():
    # the lamp's mesh grazes the walls by 5 mm; a board under it reaches 6 cm behind one: not a layout fault
    obj = lamp(0.005)
    place = placement(obj)
    post = trimesh.creation.box(bounds=[[0.1, 0.1, 0.0], [0.3, 0.3, 1.0]])
    board = trimesh.creation.box(bounds=[[0.1, -0.06, 0.0], [0.3, 0.3, 0.02]])  # body frame, 6 cm past y = 0
    pieces = [(np.asarray(p.vertices, np.float64), np.asarray(p.faces, np.int64)) for p in (post, board)]
    cut, depth = clear_of_walls(place, pieces, trimmed_walls(CORNER_SHELL))
    assert depth == {"0": pytest.approx(0.065)}
    assert place.world(cut[1][0])[:, 1].min() == pytest.approx(-2.0, abs=1e-9)


def short_wall_shell() -> RoomShell:
    """A room whose one wall (y = -2, facing +y) spans x from -2 to -1 only."""
    return RoomShell(
        floor=CORNER_SHELL.floor,
        walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (-1.0, -2.0))),),
        floor_polygon=((-2.0, -2.0), (-1.0, -2.0), (-1.0, 2.0), (-2.0, 2.0)),
        ceiling_height=2.5,
    )


def test_a_wall_plane_beyond_its_segment_cuts_nothing():
    short = short_wall_shell()
    obj = lamp(0.008)
    obj = ExportObject(1, obj.label, obj.vertices, obj.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0.5, -2.008, 0]))
    box = trimesh.creation.box(bounds=[[0.0, 0.0, 0.0], [0.4, 0.4, 1.6]])
    pieces = [(np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64))]
    _, depth = clear_of_walls(placement(obj), pieces, trimmed_walls(short))
    assert depth == {}


def test_a_piece_crossing_the_end_of_a_walls_box_between_its_vertices_is_cut():
    # a wedge whose vertices behind the plane all lie past the segment's end (x > -1): its edge still crosses
    # the plane at x = -1.0125, inside the wall's box (a wardrobe's piece in a corner the wall box stops short of)
    short = short_wall_shell()
    corners = np.array([[-1.2, -1.95], [-0.9, -2.03], [-1.2, -1.8], [-0.9, -1.8]])
    wedge = trimesh.convex.convex_hull(np.vstack([np.c_[corners, np.zeros(4)], np.c_[corners, np.ones(4)]]))
    obj = ExportObject(1, "wardrobe", wedge.vertices, wedge.faces, np.eye(4))
    pieces = [(np.asarray(wedge.vertices, np.float64), np.asarray(wedge.faces, np.int64))]
    cut, depth = clear_of_walls(placement(obj), pieces, trimmed_walls(short))
    assert depth == {"0": pytest.approx(0.03)}
    assert cut[0][0][:, 1].min() == pytest.approx(-2.0, abs=1e-9)


def test_a_tall_lamp_8_mm_into_both_walls_of_a_corner_stands(tmp_path):
    from rescene_core.sim import SimcheckConfig, simcheck_run

    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),))
    run = tmp_path / "run"
    export_scene(
        run / "scene", [lamp(0.008)], CORNER_SHELL, graph, [], ExportConfig(decomposition_cache=str(tmp_path / "c"))
    )
    report = json.loads((run / "scene/export_report.json").read_text())["objects"][0]["colliders_from_layout"]
    assert set(report["cut_at_walls"]["depth_m"]) == {"0", "1"}
    result = simcheck_run(run, SimcheckConfig())
    assert result.objects[0].penetration_t0 < 2e-3 and result.objects[0].stable
