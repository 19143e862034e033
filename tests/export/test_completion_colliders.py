"""Colliders the layout adds or changes: completions (boards, bases), hollow parents, seats, footings, clipping;
checked in MJCF and USD, in the export report and with the real physics check."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import trimesh

from rescene_core.colliders.footing import flat_base, footing
from rescene_core.colliders.pieces import BOARD_THICKNESS, Placement, clip_to_mesh, cut_seat, inside_piece
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.geometry import sim3
from rescene_core.records import (
    Completion,
    CompletionKind,
    Edge,
    InstanceId,
    Plane,
    Relation,
    RoomShell,
    Root,
    SceneGraph,
    WallPlane,
)
from rescene_core.sim import SimcheckConfig, simcheck_run
from tests.fixtures import ONE_WALL_SHELL

pytest.importorskip("mujoco")

SHELL = ONE_WALL_SHELL
SHELF_EXTENTS = (0.8, 0.35, 1.6)
YAW_180 = np.diag([-1.0, -1.0, 1.0])
SHELF_CENTRE = np.array([0.0, -2.0 + 0.175 + 0.001, 0.8])


def _board(height: float) -> np.ndarray:
    """A board polygon at world ``height`` in the shelf's asset frame (asset z = world z - 0.8)."""
    x, y = SHELF_EXTENTS[0] / 2 - 0.01, SHELF_EXTENTS[1] / 2 - 0.01
    return np.array([[-x, -y, height - 0.8], [x, -y, height - 0.8], [x, y, height - 0.8], [-x, y, height - 0.8]])


def shelf_scene(with_boards: bool) -> tuple[list[ExportObject], SceneGraph]:
    """A solid box 'generated' shelf backing onto wall 0 and a book standing inside it on a board at 0.5 m."""
    box = trimesh.creation.box(SHELF_EXTENTS)
    completions = (
        tuple(
            Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, _board(h), "parent's observed points (test)")
            for h in (0.5, 1.0)
        )
        if with_boards
        else ()
    )
    shelf = ExportObject(
        1,
        "bookshelf",
        box.vertices,
        box.faces,
        sim3.sim3_from_parts(1.0, YAW_180, SHELF_CENTRE),
        completions=completions,
    )
    book_mesh = trimesh.creation.box((0.2, 0.15, 0.25))
    book = ExportObject(
        2,
        "book",
        book_mesh.vertices,
        book_mesh.faces,
        sim3.sim3_from_parts(1.0, np.eye(3), [0.05, SHELF_CENTRE[1], 0.5 + 0.125]),
    )
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.9),
        )
    )
    return [shelf, book], graph


def _export(tmp_path, objects, graph, name="run"):
    run = tmp_path / name
    export_scene(run / "scene", objects, SHELL, graph, [], ExportConfig(decomposition_cache=str(tmp_path / "cache")))
    return run


@pytest.fixture(scope="module")
def shelf_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("shelf")
    objects, graph = shelf_scene(with_boards=True)
    return _export(tmp, objects, graph)


def test_a_book_on_a_board_inside_a_hollow_shelf_stays(shelf_run):
    result = simcheck_run(shelf_run, SimcheckConfig())
    by_node = {o.node: o for o in result.objects}
    book = by_node["obj_2_book"]
    assert book.penetration_t0 < 2e-3
    assert book.stable and book.translation < 0.01, book
    assert by_node["obj_1_bookshelf"].stable


def test_without_boards_the_solid_shelf_pushes_the_book_out(tmp_path):
    objects, graph = shelf_scene(with_boards=False)
    result = simcheck_run(_export(tmp_path, objects, graph), SimcheckConfig())
    book = {o.node: o for o in result.objects}["obj_2_book"]
    assert book.penetration_t0 > 0.05 and not book.stable


def test_report_lists_boards_and_the_open_side(shelf_run):
    report = json.loads((shelf_run / "scene/export_report.json").read_text())
    shelf = {o["node"]: o for o in report["objects"]}["obj_1_bookshelf"]
    edits = shelf["colliders_from_layout"]
    assert [c["kind"] for c in edits["completions"]] == ["support plane", "support plane"]
    assert all(c["evidence_derived"] and c["source"] for c in edits["completions"])
    assert edits["completions"][0]["height_m"] == pytest.approx(0.5, abs=1e-6)
    hollow = edits["hollow_shell"]
    # asset +y backs onto wall 0 (the shelf is turned 180 deg), so asset -y is open and faces +y in the world
    assert hollow["open_side"].startswith("-y") and "wall 0" in hollow["reason"]
    assert hollow["open_side_world"] == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)
    assert shelf["collision_method"] == "shell" and shelf["collision_pieces"] == 5 + 2
    assert report["hollow_shells"] == ["obj_1_bookshelf"] and report["completions_added"] == 2


def test_boards_are_collision_pieces_in_mjcf_and_usd(shelf_run):
    import mujoco
    from pxr import Usd, UsdPhysics

    model = mujoco.MjModel.from_xml_path(str(shelf_run / "scene/mjcf/scene.xml"))
    body = model.body("obj_1_bookshelf").id
    groups = [int(model.geom_group[g]) for g in range(model.ngeom) if model.geom_bodyid[g] == body]
    assert groups.count(3) == 7 and groups.count(1) == 1  # 5 panels + 2 boards; one visual mesh
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    tops = []
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == body and model.geom_group[g] == 3:
            mesh = model.geom_dataid[g]
            start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            local = model.mesh_vert[start : start + count]
            world = local @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
            tops.append((round(float(world[:, 2].max()), 4), round(float(np.ptp(world[:, 2])), 4)))
    assert (0.5, BOARD_THICKNESS) in tops and (1.0, BOARD_THICKNESS) in tops
    stage = Usd.Stage.Open(str(shelf_run / "scene/scene.usda"))
    shelf = stage.GetPrimAtPath("/World/Objects/obj_1_bookshelf")
    colliders = [c for c in shelf.GetChildren() if c.HasAPI(UsdPhysics.CollisionAPI)]
    assert len(colliders) == 7


def test_a_base_becomes_the_hull_of_its_points(tmp_path):
    top = trimesh.creation.box((0.6, 0.6, 0.1))  # a table top the generated mesh shows without its leg
    base_points = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.75, -0.05)])
    table = ExportObject(
        1,
        "table",
        top.vertices,
        top.faces,
        sim3.sim3_from_parts(1.0, np.eye(3), [0.0, 0.0, 0.75]),
        completions=(Completion(InstanceId(1), CompletionKind.BASE, base_points, "floor under the top (test)"),),
    )
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),))
    run = _export(tmp_path, [table], graph)
    report = json.loads((run / "scene/export_report.json").read_text())
    entry = report["objects"][0]["colliders_from_layout"]
    assert entry["completions"][0]["kind"] == "base" and entry["hollow_shell"] is None
    result = simcheck_run(run, SimcheckConfig())
    assert result.objects[0].stable and result.summary.penetration_t0_max < 1e-3  # it stands on its base


def test_cut_seat_removes_only_the_column_above_the_level():
    box = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    pieces, removed = cut_seat([(box.vertices, box.faces)], np.array([0.4, 0.4]), np.array([0.6, 0.6]), 0.5)
    assert removed == pytest.approx(0.5)
    volume = sum(trimesh.Trimesh(v, f).volume for v, f in pieces)
    assert volume == pytest.approx(1.0 - 0.2 * 0.2 * 0.5, abs=1e-9)
    centre = np.array([0.5, 0.5, 0.75])
    for v, f in pieces:
        assert not trimesh.Trimesh(v, f).contains([centre])[0]


def _place(mesh: trimesh.Trimesh) -> Placement:
    return Placement(np.eye(3), np.zeros(3), 1.0, np.asarray(mesh.vertices), np.asarray(mesh.faces))


def test_pieces_are_clipped_to_the_mesh():
    mesh = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    inflated = trimesh.creation.box(bounds=[[-0.02, 0, -0.03], [1, 1, 1]])
    pieces, reach = clip_to_mesh(_place(mesh), [(inflated.vertices, inflated.faces)])
    assert reach == pytest.approx(0.03)
    v = pieces[0][0]
    assert v.min(axis=0) == pytest.approx([0, 0, 0]) and v.max(axis=0) == pytest.approx([1, 1, 1])


def test_footing_levels_an_uneven_bottom_and_says_when_none_holds():
    # a block whose only lowest point is one corner: it would tip over that corner
    block = trimesh.creation.box(bounds=[[0, 0, 0.02], [0.5, 0.5, 0.5]])
    spike = trimesh.creation.box(bounds=[[0, 0, 0], [0.03, 0.03, 0.02]])
    mesh = trimesh.util.concatenate([block, spike])
    place = _place(mesh)
    pieces = [(block.vertices, block.faces), (spike.vertices, spike.faces)]
    piece, entry = footing(place, pieces)
    assert piece is not None and entry["support_margin_before_m"] < 0 < entry["support_margin_after_m"]
    assert piece[0][:, 2].min() == pytest.approx(0.0) and piece[0][:, :2].max() == pytest.approx(0.5)
    flat = trimesh.creation.box(bounds=[[0, 0, 0], [0.5, 0.5, 0.5]])
    assert footing(_place(flat), [(flat.vertices, flat.faces)]) == (None, None)
    # a lamp whose heavy head overhangs its small foot above half its height: no band holds its centre
    foot = trimesh.creation.box(bounds=[[0, 0, 0], [0.05, 0.05, 0.35]])
    head = trimesh.creation.box(bounds=[[0.3, 0, 0.35], [0.8, 0.5, 0.6]])
    lamp = trimesh.util.concatenate([foot, head])
    piece, entry = footing(_place(lamp), [(foot.vertices, foot.faces), (head.vertices, head.faces)])
    assert piece is None and entry["band_m"] is None


def test_a_footing_reaching_into_a_neighbour_is_cut_clear_of_it():
    # the block of the uneven-bottom test; a neighbour's geometry (one point of it) 1 cm inside the block's
    # band at its back edge: the footing is cut by a vertical plane before it and still holds the centre
    block = trimesh.creation.box(bounds=[[0, 0, 0.02], [0.5, 0.5, 0.5]])
    spike = trimesh.creation.box(bounds=[[0, 0, 0], [0.03, 0.03, 0.02]])
    place = _place(trimesh.util.concatenate([block, spike]))
    pieces = [(block.vertices, block.faces), (spike.vertices, spike.faces)]
    neighbour = np.array([[0.25, 0.49, 0.01]])
    piece, entry = footing(place, pieces, others=neighbour)
    assert piece is not None and entry["support_margin_after_m"] > 0.01 and "neighbour" in entry["why"]
    assert not inside_piece(neighbour, piece).any()
    assert piece[0][:, 1].max() < 0.49 and piece[0][:, 1].max() > 0.45  # a sliver cut off, not the whole back
    # a neighbour under the centre of mass itself: no plane keeps the centre, so no footing
    piece, entry = footing(place, pieces, others=np.array([[0.25, 0.25, 0.01]]))
    assert piece is None and "neighbour" in entry["why"]


def test_open_side_needs_a_wall_behind_it_else_faces_the_room():
    from rescene_core.colliders.hollow import hollow_shell
    from rescene_core.colliders.pieces import placement

    (shelf, book), _ = shelf_scene(with_boards=True)
    far_wall = RoomShell(
        floor=SHELL.floor,
        walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((5.0, -2.0), (9.0, -2.0))),),  # its plane, not its segment
        floor_polygon=SHELL.floor_polygon,
        ceiling_height=2.5,
    )
    _, entry = hollow_shell(shelf, placement(shelf), [placement(book)], far_wall)
    assert "into the room" in entry["reason"] and entry["open_side_world"] == pytest.approx([0, 1, 0], abs=1e-6)
    _, entry = hollow_shell(shelf, placement(shelf), [placement(book)], SHELL)
    assert "wall 0" in entry["reason"]
    # no child inside: not hollow
    assert hollow_shell(shelf, placement(shelf), [], SHELL) is None


def test_footing_counts_the_load_resting_on_the_object():
    # a table top on a narrow central pedestal 2 cm shorter than its corner legs' band: it stands alone,
    # but a 10 kg load at a corner tips it unless it gets a footing
    top = trimesh.creation.box(bounds=[[0, 0, 0.7], [1, 1, 0.75]])
    pedestal = trimesh.creation.box(bounds=[[0.45, 0.45, 0], [0.55, 0.55, 0.7]])
    legs = [
        trimesh.creation.box(bounds=[[x, y, 0.02], [x + 0.05, y + 0.05, 0.7]]) for x in (0, 0.95) for y in (0, 0.95)
    ]
    parts = [top, pedestal, *legs]
    place = _place(trimesh.util.concatenate(parts))
    pieces = [(p.vertices, p.faces) for p in parts]
    assert footing(place, pieces, 20.0) == (None, None)
    piece, entry = footing(place, pieces, 20.0, [(10.0, np.array([0.95, 0.95, 0.8]))])
    assert piece is not None and entry["support_margin_after_m"] > 0.01
    assert piece[0][:, :2].min() == pytest.approx(0.0) and piece[0][:, :2].max() == pytest.approx(1.0)


def test_a_hollow_shelf_registered_into_its_wall_is_pulled_out_of_it_with_its_base(tmp_path):
    # the shelf's back 12 mm inside wall 0 (y = -2), with a base over its whole footprint: the back panel and
    # the base are cut back to the wall's plane, so nothing starts inside the wall and the shelf stands
    import mujoco

    (shelf, book), graph = shelf_scene(with_boards=True)
    into_wall = SHELF_CENTRE + np.array([0.0, -0.013, 0.0])
    x, y = SHELF_EXTENTS[0] / 2, SHELF_EXTENTS[1] / 2
    base = np.array([[sx * x, sy * y, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-0.8, -0.75)])
    shelf = replace(
        shelf,
        world_from_asset=sim3.sim3_from_parts(1.0, YAW_180, into_wall),
        completions=(*shelf.completions, Completion(InstanceId(1), CompletionKind.BASE, base, "test base")),
    )
    book = replace(book, world_from_asset=book.world_from_asset @ sim3.sim3_from_parts(1.0, np.eye(3), [0, -0.013, 0]))
    run = _export(tmp_path, [shelf, book], graph)
    report = json.loads((run / "scene" / "export_report.json").read_text())
    edits = next(o for o in report["objects"] if o["node"] == "obj_1_bookshelf")["colliders_from_layout"]
    assert edits["hollow_shell"]["pulled_out_of_walls_m"] == {"+y": pytest.approx(0.012, abs=1e-4)}
    model = mujoco.MjModel.from_xml_path(str(run / "scene" / "mjcf" / "scene.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = model.body("obj_1_bookshelf").id
    lowest_y = np.inf
    for g in range(model.ngeom):
        if model.geom_bodyid[g] == body and model.geom_contype[g] and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            m = model.geom_dataid[g]
            v = model.mesh_vert[model.mesh_vertadr[m] : model.mesh_vertadr[m] + model.mesh_vertnum[m]]
            lowest_y = min(lowest_y, float((v @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g])[:, 1].min()))
    assert lowest_y >= -2.0 - 1e-6  # the back panel and the base both stop at the wall's plane
    result = simcheck_run(run, SimcheckConfig())
    assert result.summary.stable == result.summary.free == 2
    assert result.summary.penetration_t0_max < 0.002


def test_a_slab_carrying_things_past_its_body_gets_a_plinth_under_them():
    # a cabinet generated from its front only: a slab 4 cm deep, 0.8 m tall, with the board the capture saw
    # under the books on its top reaching 30 cm back past the slab; the books' weight tips it backwards
    slab = trimesh.creation.box(bounds=[[0, 0, 0], [0.04, 1.0, 0.8]])
    board = trimesh.creation.box(bounds=[[0, 0.1, 0.78], [0.34, 0.9, 0.8]])
    place = _place(slab)
    pieces = [(slab.vertices, slab.faces), (board.vertices, board.faces)]
    books = [(3.0, np.array([0.25, 0.5, 0.9]))]
    piece, entry = footing(place, pieces, 3.0, books)
    assert piece is None and entry["band_m"] is None  # nothing carried given: no plinth, and it says so
    piece, entry = footing(place, pieces, 3.0, books, carried_from=0.8)
    assert piece is not None and entry["support_margin_before_m"] < 0 < 0.01 < entry["support_margin_after_m"]
    lo, hi = piece[0].min(axis=0), piece[0].max(axis=0)
    assert lo == pytest.approx([0, 0, 0]) and hi[:2] == pytest.approx([0.34, 1.0])
    assert hi[2] == pytest.approx(0.8 - BOARD_THICKNESS - 0.002)  # under the board, not into the books
    # a neighbour's geometry where the plinth would stand: nothing added, and the report says why
    chair = np.array([[0.2, 0.5, 0.3]])
    piece, entry = footing(place, pieces, 3.0, books, chair, carried_from=0.8)
    assert piece is None and "without reaching into a neighbour" in entry["why"]


def _pot(seed: int = 0) -> trimesh.Trimesh:
    """A 16-sided pot 0.3 m tall, radius 0.12 m, whose bottom vertices (and 8 inside its rim) lie 0-1.8 mm
    above its lowest one, as a decomposition of a generated mesh leaves them."""
    rng = np.random.default_rng(seed)
    ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    rim = np.c_[0.12 * np.cos(ang), 0.12 * np.sin(ang)]
    inner = 0.5 * rim[::2] @ np.array([[np.cos(0.2), np.sin(0.2)], [-np.sin(0.2), np.cos(0.2)]])
    bottom = np.c_[np.vstack([rim, inner]), rng.uniform(0, 0.0018, 24)]
    return trimesh.convex.convex_hull(np.vstack([bottom, np.c_[rim, np.full(16, 0.3)]]))


def _settle_pot_with_head(pieces, tmp_path) -> float:
    """Horizontal drift (m) after 2 s in MuJoCo of a body of ``pieces`` under a 0.3 m head 0.15 m off its
    axis (centre of mass 1.7 cm inside the base's edge), on a floor box as the exporter writes it."""
    import mujoco

    for i, (v, f) in enumerate(pieces):
        trimesh.Trimesh(v, f).export(tmp_path / f"p{i}.stl")
    assets = "".join(f'<mesh name="p{i}" file="p{i}.stl"/>' for i in range(len(pieces)))
    geoms = "".join(f'<geom type="mesh" mesh="p{i}" density="300"/>' for i in range(len(pieces)))
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><compiler meshdir="{tmp_path}"/><option integrator="implicitfast"/><asset>{assets}</asset>'
        '<worldbody><geom type="box" size="2 2 0.01" pos="0 0 -0.01"/><body name="b"><freejoint/>'
        f'{geoms}<geom type="box" size="0.15 0.15 0.15" pos="0.15 0 0.6" density="300"/></body></worldbody></mujoco>'
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.xipos[1].copy()
    for _ in range(1000):
        mujoco.mj_step(model, data)
    return float(np.linalg.norm((data.xipos[1] - start)[:2]))


def test_a_flat_base_keeps_a_pot_standing_that_its_uneven_facets_tip(tmp_path):
    pot = _pot()
    place = _place(pot)
    flat, entry = flat_base(place, [(pot.vertices, pot.faces)])
    low = int((pot.vertices[:, 2] < 0.002).sum())  # the rim's 16 and those inside it that are hull vertices
    assert low > 16 and entry is not None and entry["vertices_lowered"] == low - 1
    assert 0.0015 < entry["max_lowered_m"] <= 0.002
    v = flat[0][0]
    level = pot.vertices[:, 2].min()
    assert (np.isclose(v[:, 2], level, atol=1e-9) | np.isclose(v[:, 2], 0.3)).all()  # one level, the top untouched
    assert len(v) == 32  # the vertices inside the rim are no longer vertices of the hull
    # MuJoCo's face contact keeps one facet of the uneven bottom and the pot tips over its edge; flat, it stands
    (tmp_path / "uneven").mkdir()
    (tmp_path / "flat").mkdir()
    assert _settle_pot_with_head([(pot.vertices, pot.faces)], tmp_path / "uneven") > 0.1
    assert _settle_pot_with_head(flat, tmp_path / "flat") < 0.005
    # nothing within the band: unchanged, no entry
    box = trimesh.creation.box(bounds=[[0, 0, 0], [0.5, 0.5, 0.5]])
    assert flat_base(_place(box), [(box.vertices, box.faces)])[1] is None


def test_a_child_on_a_shelf_of_the_generated_mesh_keeps_that_shelf_in_the_hollow_shell(tmp_path):
    # the shelf scene with one support plane (0.5 m, under the first book) and a board of the mesh itself at
    # 1.1 m (world), which the layout found no points of, under a second book: the shell's panels are the
    # mesh's box, so without a board there the second book falls to the first
    objects, graph = shelf_scene(with_boards=False)
    inner = trimesh.creation.box(bounds=[[-0.39, -0.165, 0.28], [0.39, 0.165, 0.30]])  # asset z = world z - 0.8
    mesh = trimesh.util.concatenate([trimesh.creation.box(SHELF_EXTENTS), inner])
    shelf = replace(
        objects[0],
        vertices=mesh.vertices,
        faces=mesh.faces,
        completions=(Completion(InstanceId(1), CompletionKind.SUPPORT_PLANE, _board(0.5), "test"),),
    )
    top_book = replace(
        objects[1], instance=3, world_from_asset=sim3.sim3_from_parts(1.0, np.eye(3), [-0.1, SHELF_CENTRE[1], 1.225])
    )
    graph = SceneGraph((*graph.edges, Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(1), 0.9)))
    run = _export(tmp_path, [shelf, objects[1], top_book], graph)
    report = json.loads((run / "scene" / "export_report.json").read_text())
    entry = next(o for o in report["objects"] if o["instance"] == 1)["colliders_from_layout"]["hollow_shell"]
    assert entry["inner_support_planes_m"] == [0.5] and entry["shelves_from_mesh_m"] == [pytest.approx(1.1)]
    by_node = {o.node: o for o in simcheck_run(run, SimcheckConfig()).objects}
    assert by_node["obj_3_book"].stable and by_node["obj_3_book"].translation < 0.01
    assert by_node["obj_2_book"].stable
