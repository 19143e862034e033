"""A room larger than what was seen: the floor seen in a patch, two walls seen, a kitchen island seen only
from above on floor never in view, and the cameras standing beyond the patch. The floor's extent takes in the
island and the cameras, the sides without a wall are open, the island is not moved by attachment, and the
exported walls are the observed ones only."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon

from rescene_core.assembly import attach
from rescene_core.assembly.scenes import box_object, placed
from rescene_core.capture import open_capture, write_capture
from rescene_core.config import AttachmentConfig, ExportConfig
from rescene_core.export.shell import shell_meshes
from rescene_core.records import Edge, InstanceId, Relation, RoomShell, Root, SceneGraph
from rescene_core.shell import estimate_shell, load_shell, plot_shell, save_shell
from tests.fixtures import Box, box_capture_arrays, look_at, pinhole

THIN = 0.002
ISLAND = ((2.8, 0.8), (4.0, 1.6))
"""The island's footprint corners (m); only its top (0.88-0.90 m) was seen."""
CAMERAS = [(3.4, 2.5, 1.6), (3.0, 2.7, 1.65)]


@pytest.fixture(scope="module")
def shell(tmp_path_factory) -> RoomShell:
    (x0, y0), (x1, y1) = ISLAND
    boxes = [
        Box(1, "floor", (0.0, 0.0, -THIN), (2.0, 2.0, 0.0), (150, 130, 110), True),  # the floor seen: a patch
        Box(2, "wall", (0.0, -THIN, 0.0), (2.5, 0.0, 2.5), (225, 225, 215), True),  # y = 0, seen for 2.5 m
        Box(3, "wall", (-THIN, 0.0, 0.0), (0.0, 2.0, 2.5), (225, 225, 215), True),  # x = 0, seen for 2 m
        Box(10, "kitchen island", (x0, y0, 0.88), (x1, y1, 0.90), (200, 40, 40)),
    ]
    poses = np.asarray([look_at(np.array(c), np.array([3.4, 1.2, 0.9])) for c in CAMERAS])
    arrays = box_capture_arrays(boxes, poses, pinhole(64, 48, 50.0), 64, 48, point_density=4000.0, scene_id="open-room")
    path = write_capture(tmp_path_factory.mktemp("open") / "open.zarr", arrays)
    return estimate_shell(open_capture(path, validate=False))


def _island_fp() -> Polygon:
    (x0, y0), (x1, y1) = ISLAND
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def test_extent_takes_in_the_island_and_the_cameras(shell):
    seen, extent = Polygon(shell.seen_floor_polygon), shell.polygon()
    assert extent.is_valid and extent.exterior.is_ccw
    assert not seen.intersects(_island_fp())  # the island stands on floor never in view
    assert extent.buffer(0.02).contains(_island_fp())
    for x, y, _ in CAMERAS:
        assert extent.buffer(0.02).contains(Point(x, y))
    assert extent.contains(seen.buffer(-0.02))
    # nothing of it behind the two observed walls
    minx, miny, _, _ = extent.bounds
    assert minx >= -0.03 and miny >= -0.03


def test_edges_name_the_observed_walls_and_the_rest_is_open(shell):
    assert len(shell.walls) == 2 and shell.edge_walls is not None
    assert len(shell.edge_walls) == len(shell.floor_polygon)
    assert {w.id for w in shell.walls} == {t for t in shell.edge_walls if t is not None}
    assert shell.open_edges()
    ring = list(shell.floor_polygon)
    for k, tag in enumerate(shell.edge_walls):
        a, b = np.asarray(ring[k]), np.asarray(ring[(k + 1) % len(ring)])
        on_a_wall_line = [
            w.id
            for w in shell.walls
            if max(abs(float(np.dot(w.plane.normal[:2], p)) + w.plane.offset) for p in (a, b)) < 0.05
        ]
        if tag is not None:
            assert tag in on_a_wall_line
        # an open edge lies along no observed wall's segment
        for w in shell.walls if tag is None else ():
            assert LineString([a, b]).intersection(LineString(w.segment).buffer(0.05)).length < 0.35


def test_version_2_round_trip_and_version_1_reads_as_walled(shell, tmp_path):
    back = load_shell(save_shell(tmp_path / "shell.json", shell))
    assert back == shell
    v1 = {k: v for k, v in shell.to_json().items() if k not in ("version", "edge_walls", "seen_floor_polygon")}
    old = RoomShell.from_json(v1)
    assert old.edge_walls is None and old.open_edges() == () and old.floor_polygon == shell.floor_polygon


def test_walls_are_exported_only_where_observed(shell):
    meshes = shell_meshes(shell, ExportConfig())
    walls = {k: m for k, m in meshes.items() if k.startswith("shell_wall_")}
    assert set(walls) == {f"shell_wall_{w.id}" for w in shell.walls}
    ring = list(shell.floor_polygon)
    edges = [LineString([ring[k], ring[(k + 1) % len(ring)]]) for k in range(len(ring))]
    for k, tag in enumerate(shell.edge_walls or ()):
        if tag is not None:
            continue
        # no wall box stands along an open side (beyond the corners it shares with a walled side)
        inner = edges[k].interpolate(0.25, normalized=True), edges[k].interpolate(0.75, normalized=True)
        for mesh in walls.values():
            footprint = Polygon(np.asarray(mesh.vertices)[:, :2]).convex_hull
            assert all(footprint.distance(p) > 0.1 for p in inner)
    for w in shell.walls:  # each box lies behind its own wall, along the edge tagged with it
        centre = np.asarray(walls[f"shell_wall_{w.id}"].bounds).mean(axis=0)
        assert float(np.dot(w.plane.normal[:2], centre[:2])) + w.plane.offset < 0
        tagged = [edges[k] for k, t in enumerate(shell.edge_walls or ()) if t == w.id]
        assert tagged and min(e.distance(Point(centre[:2])) for e in tagged) < 0.05


def test_the_island_on_unseen_floor_is_not_moved(shell):
    (x0, y0), (x1, y1) = ISLAND
    island = box_object(10, "kitchen island", (x1 - x0, y1 - y0, 0.9), placed((x0 + x1) / 2, (y0 + y1) / 2))
    cup = box_object(11, "cup", (0.08, 0.08, 0.1), placed(3.2, 1.1, 0.9))
    graph = SceneGraph(
        (Edge(InstanceId(10), Relation.RESTS_ON, Root.FLOOR), Edge(InstanceId(11), Relation.RESTS_ON, InstanceId(10)))
    )
    objects = {island.instance: island, cup.instance: cup}
    layout = attach(objects, graph, shell, AttachmentConfig())
    for i, obj in objects.items():
        moved = layout.world_from_asset[i][:3, 3] - obj.world_from_asset[:3, 3]
        assert np.linalg.norm(moved[:2]) < 1e-6


def test_plot_shows_the_open_sides(shell, tmp_path):
    png = plot_shell(tmp_path / "shell.png", shell)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000
