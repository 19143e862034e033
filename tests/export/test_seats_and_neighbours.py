"""Where colliders meet: a parent's pieces carved where its children stand (seats, hollow shells, inner
shelves), boards under a child's foot, completions kept to the mesh's footprint, and neighbours' pieces cut
apart where neither object is; checked on the geometry, in the export report and with the physics check."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from rescene_core.colliders.edits import completion_pieces
from rescene_core.colliders.footing import FOOTING_MARGIN, footing
from rescene_core.colliders.pieces import Placement, carve, inside_piece, placement
from rescene_core.colliders.seats import Seated, seat_children
from rescene_core.colliders.separate import evidence_points, overlaps, separate
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.geometry import sim3
from rescene_core.records import (
    Completion,
    CompletionKind,
    Edge,
    InstanceId,
    Relation,
    RoomShell,
    Root,
    SceneGraph,
)
from rescene_core.sim import SimcheckConfig, simcheck_run
from tests.fixtures import CORNER_SHELL, ONE_WALL_SHELL

pytest.importorskip("mujoco")


def _box(lo, hi) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=np.array([lo, hi], np.float64))


def _piece(mesh: trimesh.Trimesh):
    return (np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64))


def _place(mesh: trimesh.Trimesh, at=(0.0, 0.0, 0.0)) -> Placement:
    return Placement(np.eye(3), np.asarray(at, np.float64), 1.0, np.asarray(mesh.vertices), np.asarray(mesh.faces))


def _volume(pieces) -> float:
    return sum(abs(trimesh.Trimesh(v, f).volume) for v, f in pieces)


def test_carve_removes_the_prism_between_two_heights_and_keeps_pieces_convex():
    pieces, removed = carve(
        [_piece(_box([0, 0, 0], [1, 1, 1]))], np.array([[0.4, 0.4], [0.6, 0.4], [0.6, 0.6], [0.4, 0.6]]), 0.5, 0.8
    )
    assert removed == pytest.approx(0.3)
    assert _volume(pieces) == pytest.approx(1.0 - 0.2 * 0.2 * 0.3, abs=1e-9)
    for v, f in pieces:
        mesh = trimesh.Trimesh(v, f)
        assert mesh.is_convex and not mesh.contains([[0.5, 0.5, 0.65]])[0]
    assert any(trimesh.Trimesh(v, f).contains([[0.5, 0.5, 0.9]])[0] for v, f in pieces)  # above: kept
    untouched, removed = carve([_piece(_box([0, 0, 0], [1, 1, 1]))], np.array([[2, 2], [3, 2], [3, 3], [2, 3]]), 0, 1)
    assert removed == 0.0 and len(untouched) == 1


def _table_and_book(sunk: float, boards: tuple[float, ...] = ()):
    """A solid 1 x 1 x 0.8 'table' and a 0.2 m cube whose bottom is ``sunk`` m below the table's top."""
    table = _box([-0.5, -0.5, 0], [0.5, 0.5, 0.8])
    book = _box([-0.1, -0.1, 0.8 - sunk], [0.1, 0.1, 1.0 - sunk])
    return table, book, [0.8 - sunk for _ in boards]


def test_a_child_inside_its_parents_mesh_is_left_unless_a_support_plane_is_at_its_feet():
    table, book, _ = _table_and_book(0.05)
    parent, child = _place(table), _place(book)
    seated = [Seated("obj_2_book", child, [_piece(book)], True)]
    pieces, seats, boards = seat_children(parent, [_piece(table)], seated)
    assert seats[0]["cut"] is False and "layout fault" in seats[0]["why"] and not boards
    assert seats[0]["mesh_overlap_m"] == pytest.approx(0.05, abs=5e-3)
    assert _volume(pieces) == pytest.approx(0.8)
    # the layout found a board at the child's feet (an inner shelf the mesh lacks): carved, board under it
    board = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]) * 0.1  # smaller than the book
    pieces, seats, boards = seat_children(parent, [_piece(table)], seated, supports=[(0.75, board)])
    assert seats[0]["cut"] is True and "support plane" in seats[0]["why"]
    assert boards and boards[0]["height_m"] == pytest.approx(0.75)
    probe = np.array([[0.0, 0.0, 0.78]])  # inside the book, inside the table's mesh
    assert not any(trimesh.Trimesh(v, f).contains(probe)[0] for v, f in pieces)


def test_a_ridge_of_the_parents_mesh_under_a_third_of_the_childs_foot_is_carved_and_a_sunk_child_is_not():
    # a cabinet's generated top at 0.76 m with a 4 cm wide ridge 2.3 cm high across it; a 23 x 33 cm book stack
    # standing on the top across the ridge (cluttered diagnostic seed 205)
    top = _box([-0.5, -0.3, 0.0], [0.5, 0.3, 0.76])
    ridge = _box([-0.02, -0.3, 0.76], [0.02, 0.3, 0.783])
    cabinet = trimesh.util.concatenate([top, ridge])
    book = _box([-0.115, -0.165, 0.76], [0.115, 0.165, 0.87])
    seated = [Seated("obj_2_book_stack", _place(book), [_piece(book)], True)]
    pieces, seats, _ = seat_children(_place(cabinet), [_piece(top), _piece(ridge)], seated)
    assert seats[0]["cut"] is True and "ridge" in seats[0]["why"]
    assert seats[0]["mesh_overlap_m"] == pytest.approx(0.023, abs=2e-3)  # the mesh overlap is still reported
    assert 0.0 < seats[0]["raised_share"] <= 1.0 / 3.0
    assert not any(trimesh.Trimesh(v, f).contains([[0.0, 0.0, 0.77]])[0] for v, f in pieces)
    # a child sunk 5 cm into its parent's whole top stays a layout fault
    table, sunk, _ = _table_and_book(0.05)
    _, seats, _ = seat_children(_place(table), [_piece(table)], [Seated("b", _place(sunk), [_piece(sunk)], True)])
    assert seats[0]["cut"] is False and "layout fault" in seats[0]["why"]


def test_a_seat_cut_through_a_thin_top_panel_keeps_a_floor_under_the_child():
    # a desk's hollow shell: a 2.2 cm top panel (0.967-0.989 m) over an empty inside; a lamp whose generated
    # base stands 1.2 cm lower (0.955 m), in a dip of the desk's top, so the panel runs through the lamp
    desk = _box([-0.6, -0.3, 0.0], [0.6, 0.3, 0.989])
    panel = _box([-0.6, -0.3, 0.967], [0.6, 0.3, 0.989])
    lamp = _box([-0.05, -0.05, 0.955], [0.05, 0.05, 1.25])
    seated = [Seated("obj_2_lamp", _place(lamp), [_piece(lamp)], True)]
    pieces, seats, boards = seat_children(_place(desk), [_piece(panel)], seated, hollow=True)
    assert seats[0]["cut"] is True
    (floor,) = boards
    assert floor["child"] == "obj_2_lamp" and floor["height_m"] == pytest.approx(0.955)
    assert floor["support_plane_m"] is None and "floor" in floor["why"]
    below_foot = np.array([[0.0, 0.0, 0.95], [0.04, -0.04, 0.95]])
    assert all(any(trimesh.Trimesh(v, f).contains(below_foot[i : i + 1])[0] for v, f in pieces) for i in range(2))
    assert not any(trimesh.Trimesh(v, f).contains([[0.0, 0.0, 0.97]])[0] for v, f in pieces)  # the seat is cut
    # a child resting on one of the parent's children gets no floor from the parent
    _, _, none = seat_children(
        _place(desk), [_piece(panel)], [Seated("x", _place(lamp), [_piece(lamp)], False)], hollow=True
    )
    assert none == []


def test_pieces_that_fill_a_concavity_under_a_child_are_carved():
    # a tray: its mesh dips 5 cm where the cup stands, its single convex piece fills the dip
    tray = trimesh.boolean.difference(
        [_box([-0.5, -0.5, 0], [0.5, 0.5, 0.3]), _box([-0.15, -0.15, 0.25], [0.15, 0.15, 0.31])], engine="manifold"
    )
    cup = _box([-0.1, -0.1, 0.25], [0.1, 0.1, 0.4])
    pieces, seats, _ = seat_children(
        _place(tray), [_piece(tray.convex_hull)], [Seated("c", _place(cup), [_piece(cup)], True)]
    )
    assert seats[0]["cut"] is True and seats[0]["depth_m"] == pytest.approx(0.05, abs=1e-3)
    assert seats[0]["mesh_overlap_m"] <= 0.02
    top_under_cup = max(float(v[:, 2].max()) for v, _ in pieces if np.abs(v[:, :2]).max() < 0.11)
    assert top_under_cup == pytest.approx(0.25, abs=1e-6)


def thin_shelf_scene(shell: RoomShell = ONE_WALL_SHELL, x0: float = 0.0, width: float = 0.2, back: float = 0.025):
    """A generated 'bookshelf' only 12 cm deep and 30 cm wide against wall 0 (its back at y = -2) with a
    board at 0.5 m (10 cm deep), and a box ``width`` wide and 30 cm deep standing on the board, its back
    ``back`` m in front of the wall: its centre is 4-6 cm in front of the board."""
    shelf_mesh = _box([-0.15, -0.06, -0.8], [0.15, 0.06, 0.8])
    y0 = -2.0 + 0.06 + 0.001
    board = np.array([[x, y, 0.5 - 0.8] for x, y in ((-0.14, -0.05), (0.14, -0.05), (0.14, 0.05), (-0.14, 0.05))])
    shelf = ExportObject(
        1,
        "bookshelf",
        shelf_mesh.vertices,
        shelf_mesh.faces,
        sim3.sim3_from_parts(1.0, np.eye(3), [x0, y0, 0.8]),
        completions=(Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, board, "parent's points (test)"),),
    )
    box_mesh = _box([-width / 2, 0, 0], [width / 2, 0.3, 0.1])
    box = ExportObject(
        2, "box", box_mesh.vertices, box_mesh.faces, sim3.sim3_from_parts(1.0, np.eye(3), [x0, -2.0 + back, 0.5])
    )
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.9),
        )
    )
    return [shelf, box], graph, shell


def _export(tmp_path, objects, graph, shell, name="run"):
    run = tmp_path / name
    export_scene(run / "scene", objects, shell, graph, [], ExportConfig(decomposition_cache=str(tmp_path / "cache")))
    return run


def _stays(run) -> dict:
    result = simcheck_run(run, SimcheckConfig())
    by_node = {o.node: o for o in result.objects}
    assert by_node["obj_2_box"].penetration_t0 < 2e-3
    assert by_node["obj_2_box"].stable and by_node["obj_1_bookshelf"].stable
    report = json.loads((run / "scene/export_report.json").read_text())
    return {o["node"]: o for o in report["objects"]}["obj_1_bookshelf"]["colliders_from_layout"]


def test_a_box_deeper_than_a_thin_generated_shelf_stands_on_the_board_under_its_foot(tmp_path):
    shelf = _stays(_export(tmp_path, *thin_shelf_scene()))
    assert shelf["hollow_shell"] is not None and not shelf["seats_cut"]
    board = shelf["boards_under_children"][0]
    assert board["child"] == "obj_2_box" and board["height_m"] == pytest.approx(0.5)


def test_a_box_wider_than_a_thin_generated_shelf_has_its_side_panels_carved(tmp_path):
    shelf = _stays(_export(tmp_path, *thin_shelf_scene(width=0.4, back=0.005)))
    seat = shelf["seats_cut"][0]
    assert seat["child"] == "obj_2_box" and seat["cut"] and "hollow shell" in seat["why"]
    assert seat["depth_m"] == pytest.approx(0.1, abs=3e-3)  # its height, through both side panels


def test_a_shelf_in_a_corner_opens_towards_the_room():
    from rescene_core.colliders.hollow import hollow_shell

    objects, _, _ = thin_shelf_scene(CORNER_SHELL, x0=-2.0 + 0.151)
    shelf, book = objects
    _, entry = hollow_shell(shelf, placement(shelf), [placement(book)], CORNER_SHELL)
    assert "corner" in entry["reason"]
    assert entry["open_side_world"] == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)  # not into wall 1 at x = -2


def test_completions_stay_within_the_meshs_footprint():
    top = _box([-0.5, -0.5, 0.7], [0.5, 0.5, 0.75])
    # a base reaching 10 cm past the top's edge (a later cut of the mesh left it there)
    base = np.array([[x, y, z] for x in (-0.3, 0.6) for y in (-0.3, 0.3) for z in (0.0, 0.7)])
    obj = ExportObject(
        1,
        "table",
        top.vertices,
        top.faces,
        np.eye(4),
        completions=(Completion(InstanceId(1), CompletionKind.BASE, base, "test"),),
    )
    pieces, entries = completion_pieces(obj, placement(obj))
    assert entries[0]["clipped_to_footprint_m"] == pytest.approx(0.1)
    assert pieces[0][0][:, 0].max() == pytest.approx(0.5) and pieces[0][0][:, 2].min() == pytest.approx(0.0)


def test_neighbours_pieces_are_cut_apart_where_neither_object_is():
    a_mesh, b_mesh = _box([0, 0, 0], [1, 1, 1]), _box([1.05, 0, 0], [2, 1, 1])
    places = {"a": _place(a_mesh), "b": _place(b_mesh)}
    pieces = {"a": [_piece(_box([0, 0, 0], [1.1, 1, 1]))], "b": [_piece(b_mesh)]}  # a's piece reaches 10 cm past it
    evidence = {n: evidence_points(p) for n, p in places.items()}
    rows = separate(places, pieces, evidence, set())
    assert rows["a"][0]["neighbour"] == "b" and rows["a"][0]["pieces_cut"] == 1
    assert rows["a"][0]["depth_m"] == pytest.approx(0.05, abs=1e-3)
    assert pieces["a"][0][0][:, 0].max() == pytest.approx(1.025, abs=1e-6)  # midway between the meshes
    assert pieces["b"][0][0][:, 0].min() == pytest.approx(1.05, abs=1e-6)
    assert overlaps({n: ps for n, ps in pieces.items()}) == []


def test_a_piece_filling_a_concavity_a_neighbour_stands_in_is_carved_there():
    # a U-shaped object (two posts on a slab) whose single convex piece fills the notch, and a neighbour in
    # the notch touching neither post nor slab: no plane separates the two, the notch is carved out of the piece
    u_mesh = trimesh.util.concatenate(
        [_box([0, 0, 0], [1, 1, 0.2]), _box([0, 0, 0.2], [0.1, 1, 1]), _box([0.9, 0, 0.2], [1, 1, 1])]
    )
    b_mesh = _box([0.3, 0.3, 0.25], [0.7, 0.7, 0.6])
    places = {"a": _place(u_mesh), "b": _place(b_mesh)}
    pieces = {"a": [_piece(u_mesh.convex_hull)], "b": [_piece(b_mesh)]}
    rows = separate(places, pieces, {n: evidence_points(p) for n, p in places.items()}, set())
    assert rows["a"][0]["pieces_carved"] == 1 and "carved" in rows["a"][0]["why"]
    assert "objects_overlap_m" not in rows["a"][0]
    assert overlaps(pieces) == []
    assert all(_is_convex(p) for p in pieces["a"])
    # the posts and the slab keep their pieces: only the notch's prism is gone (0.404^2 x 0.354 m)
    assert _volume(pieces["a"]) == pytest.approx(1.0 - 0.404 * 0.404 * 0.354, abs=1e-3)
    assert pieces["b"][0][0][:, 0].min() == pytest.approx(0.3)  # the neighbour is not touched


def test_a_board_yields_to_a_neighbours_mesh_where_its_own_mesh_is_not():
    # a table top with a board the layout added below it (a shelf its mesh lacks), and a neighbour's mesh
    # passing through the board's corner: the board is carved there, the neighbour keeps its piece
    top = _box([0, 0, 0.7], [1, 1, 0.75])
    board = _piece(_box([0, 0, 0.3], [1, 1, 0.32]))
    b_mesh = _box([0.8, 0.4, 0.0], [1.2, 0.6, 0.6])
    places = {"a": _place(top), "b": _place(b_mesh)}
    pieces = {"a": [_piece(top), board], "b": [_piece(b_mesh)]}
    evidence = {"a": evidence_points(places["a"], [board]), "b": evidence_points(places["b"])}
    rows = separate(places, pieces, evidence, set(), {"a": [board]})
    assert rows["a"][0]["pieces_carved"] == 1 and "objects_overlap_m" not in rows["a"][0]
    assert overlaps(pieces) == []
    assert _volume(pieces["a"]) == pytest.approx(0.05 + 0.02 - 0.202 * 0.204 * 0.02, abs=1e-6)
    assert pieces["b"][0][0][:, 0].min() == pytest.approx(0.8)


def _is_convex(piece) -> bool:
    mesh = trimesh.Trimesh(*piece)
    return bool(abs(mesh.volume - mesh.convex_hull.volume) < 1e-6)


def test_neighbours_that_overlap_themselves_are_reported_and_one_piece_gives_way():
    # two boxes whose meshes overlap by 5 cm (a layout fault): no plane separates them and neither can be
    # carved; b has the smaller share of itself inside a's piece (5 of its 105 cm), so b's piece gives way
    a_mesh, b_mesh = _box([0, 0, 0], [1, 1, 1]), _box([0.95, 0, 0], [2, 1, 1])
    places = {"a": _place(a_mesh), "b": _place(b_mesh)}
    pieces = {"a": [_piece(a_mesh)], "b": [_piece(b_mesh)]}
    rows = separate(places, pieces, {n: evidence_points(p) for n, p in places.items()}, set())
    assert rows["b"][0]["pieces_cut"] == 0 and rows["b"][0]["meshes_overlap_m"] == pytest.approx(0.05, abs=1e-3)
    assert "layout fault" in rows["b"][0]["why"] and rows["b"][0]["pieces_subtracted"] == 1
    assert "pieces_subtracted" not in rows["a"][0] and "layout fault" in rows["a"][0]["why"]
    assert pieces["a"][0][0][:, 0].max() == pytest.approx(1.0)
    assert len(pieces["b"]) == 1 and pieces["b"][0][0][:, 0].min() == pytest.approx(1.0)
    assert overlaps(pieces) == []
    # a child and its parent are the seats' business, not this
    pieces = {"a": [_piece(a_mesh)], "b": [_piece(b_mesh)]}
    assert separate(places, pieces, {n: evidence_points(p) for n, p in places.items()}, {frozenset("ab")}) == {}


def test_a_solid_block_gives_way_to_a_chair_tucked_into_it():
    # a generated table completed as a solid block down to the floor, and a chair (seat and back) whose seat
    # is under the table's top, inside the block: the block's piece gives way around the chair's pieces,
    # in convex parts; the chair keeps its pieces
    table = _box([0, 0, 0], [1.2, 0.8, 0.75])
    seat, back = _box([0.4, 0.45, 0.0], [0.8, 0.8, 0.45]), _box([0.4, 0.75, 0.45], [0.8, 0.8, 0.9])
    chair = trimesh.util.concatenate([seat, back])
    places = {"table": _place(table), "chair": _place(chair)}
    pieces = {"table": [_piece(table)], "chair": [_piece(seat), _piece(back)]}
    rows = separate(places, pieces, {n: evidence_points(p) for n, p in places.items()}, set())
    assert rows["table"][0]["pieces_subtracted"] >= 1 and "layout fault" in rows["table"][0]["why"]
    assert "pieces_subtracted" not in rows["chair"][0]
    assert overlaps(pieces) == []
    assert all(_is_convex(p) for p in pieces["table"])
    assert _volume(pieces["chair"]) == pytest.approx(0.4 * 0.35 * 0.45 + 0.4 * 0.05 * 0.45, abs=1e-6)
    # the block loses what the seat and the back (up to the block's top) fill of it, and at most the few
    # millimetres of the plane cuts and carves that came first (the back's top edge, cut midway)
    kept = 1.2 * 0.8 * 0.75 - 0.4 * 0.35 * 0.45 - 0.4 * 0.05 * 0.3
    assert kept - 0.003 < _volume(pieces["table"]) <= kept + 1e-6


def test_footing_bands_reach_half_the_height_and_no_further():
    # a lamp whose head, beside its foot, starts at 40 % of its height: the 50 % band holds it
    foot = _box([0, 0, 0], [0.05, 0.05, 0.24])
    head = _box([0.1, 0, 0.24], [0.3, 0.2, 0.6])
    lamp = trimesh.util.concatenate([foot, head])
    piece, entry = footing(_place(lamp), [_piece(foot), _piece(head)])
    assert piece is not None and entry["band_fraction_of_height"] == 0.5
    # a head starting above half the height is not reached
    head = _box([0.1, 0, 0.35], [0.3, 0.2, 0.6])
    lamp = trimesh.util.concatenate([_box([0, 0, 0], [0.05, 0.05, 0.35]), head])
    piece, entry = footing(_place(lamp), [_piece(_box([0, 0, 0], [0.05, 0.05, 0.35])), _piece(head)])
    assert piece is None and entry["band_m"] is None


def test_a_footing_resists_the_tilt_the_check_calls_stable():
    # a pot on a narrow foot: the foot's own band holds the centre 13 mm inside, but the centre is 16 cm up,
    # where a 5 deg tilt moves it 14 mm: the band grows to the body's bottom (15 %), which holds it
    body, stem = _box([0.0, 0.0, 0.04], [0.2, 0.1, 0.3]), _box([0.06, 0.0, 0.008], [0.1, 0.1, 0.04])
    plant = trimesh.util.concatenate([_box([0.05, 0.0, 0.0], [0.112, 0.1, 0.008]), stem, body])
    pieces = [_piece(_box([0.05, 0.0, 0.0], [0.105, 0.1, 0.008])), _piece(stem), _piece(body)]  # a short piece
    piece, entry = footing(_place(plant), pieces)
    assert piece is not None and entry["band_fraction_of_height"] == 0.15
    assert entry["support_margin_after_m"] >= entry["tilt_margin_m"] == pytest.approx(0.0143, abs=2e-4)
    # a neighbour under the body's far end: the band resisting the tilt is cut clear of it and still resists
    piece, entry = footing(_place(plant), pieces, others=np.array([[0.18, 0.05, 0.02]]))
    assert piece is not None and entry["band_fraction_of_height"] == 0.15 and "neighbour" in entry["why"]
    assert not inside_piece(np.array([[0.18, 0.05, 0.02]]), piece).any()
    assert entry["support_margin_after_m"] >= entry["tilt_margin_m"]
    # a neighbour right under the centre: no band resisting the tilt fits, the first band holding it does
    piece, entry = footing(_place(plant), pieces, others=np.array([[0.1, 0.05, 0.02]]))
    assert piece is not None and entry["band_fraction_of_height"] == 0.02
    assert FOOTING_MARGIN <= entry["support_margin_after_m"] < entry["tilt_margin_m"]


def test_a_footing_does_not_reach_into_a_neighbour():
    foot = _box([0, 0, 0], [0.05, 0.05, 0.24])
    head = _box([0.1, 0, 0.24], [0.3, 0.2, 0.6])
    lamp = trimesh.util.concatenate([foot, head])
    pieces = [_piece(foot), _piece(head)]
    assert footing(_place(lamp), pieces, others=np.array([[2.0, 2.0, 0.1]]))[0] is not None  # far away
    # a neighbour's mesh under the lamp's head, where the 50 % footing would fill
    piece, entry = footing(_place(lamp), pieces, others=np.array([[0.2, 0.1, 0.1]]))
    assert piece is None and entry["band_m"] is None and "neighbour" in entry["why"]


def test_inside_piece_ignores_degenerate_faces():
    from rescene_core.colliders.pieces import inside_piece

    box = _box([0, 0, 0], [1, 1, 1])
    faces = np.vstack([box.faces, [[0, 0, 1]]])  # a zero-area face, as a hull of near-duplicate points can have
    piece = (np.asarray(box.vertices, np.float64), faces)
    assert inside_piece(np.array([[0.5, 0.5, 0.5], [0.999, 0.5, 0.5], [1.5, 0.5, 0.5]]), piece).tolist() == [
        True,
        False,
        False,
    ]


def test_a_stack_poking_through_a_shelfs_side_has_its_seat_carved_with_the_board_it_carries(tmp_path):
    """A box wider than a thin shelf carries a smaller box on a support plane inside it that reaches past
    its side, through the shelf's side panel: the board under the small box's foot is one of the box's
    pieces before the shelf carves its seat, so no panel is left inside that board."""
    objects, graph, shell = thin_shelf_scene(width=0.2, back=0.005)
    plane = np.array([[x, y, 0.05] for x, y in ((-0.09, 0.01), (0.09, 0.01), (0.09, 0.29), (-0.09, 0.29))])
    box = objects[1]
    objects[1] = ExportObject(
        box.instance,
        box.label,
        box.vertices,
        box.faces,
        box.world_from_asset,
        completions=(Completion(InstanceId(2), CompletionKind.SUPPORT_PLANE, plane, "parent's points (test)"),),
    )
    small = _box([0.0, 0.05, 0.0], [0.2, 0.25, 0.08])
    objects.append(
        ExportObject(3, "box", small.vertices, small.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0.0, -1.995, 0.55]))
    )
    graph = SceneGraph((*graph.edges, Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(2), 0.9)))
    run = _export(tmp_path, objects, graph, shell)
    report = {o["node"]: o for o in json.loads((run / "scene/export_report.json").read_text())["objects"]}
    assert report["obj_2_box"]["colliders_from_layout"]["boards_under_children"][0]["child"] == "obj_3_box"
    result = simcheck_run(run, SimcheckConfig())
    by_node = {o.node: o for o in result.objects}
    assert by_node["obj_2_box"].penetration_t0 < 2e-3
    assert by_node["obj_2_box"].stable and by_node["obj_3_box"].stable
