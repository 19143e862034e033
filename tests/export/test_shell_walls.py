"""Wall boxes of the exported shell: estimated segments that overshoot a corner the room turns around are
trimmed back to the room's outline, so furniture in that corner does not start inside a wall."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.shell import shell_meshes
from rescene_core.geometry.room import wall_extent
from rescene_core.paths import RunPaths
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane
from rescene_core.sim import SimcheckConfig, simcheck_run

pytest.importorskip("mujoco")

# an L-shaped room: the 4 x 2 m main part (y < 2) and a 2 x 2 m wing (x < 2, y > 2); the wall along y = 2
# closes the main part for x > 2, its estimated segment overshooting the inner corner (2, 2) by 3 cm
OVERSHOOT = 0.03
L_ROOM = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(
        WallPlane(0, Plane((0.0, 1.0, 0.0), 0.0), ((4.0, 0.0), (0.0, 0.0))),
        WallPlane(1, Plane((-1.0, 0.0, 0.0), 4.0), ((4.0, 2.0), (4.0, 0.0))),
        WallPlane(2, Plane((0.0, -1.0, 0.0), 2.0), ((2.0 - OVERSHOOT, 2.0), (4.0, 2.0))),
        WallPlane(3, Plane((-1.0, 0.0, 0.0), 2.0), ((2.0, 4.0), (2.0, 2.0))),
        WallPlane(4, Plane((0.0, -1.0, 0.0), 4.0), ((0.0, 4.0), (2.0, 4.0))),
        WallPlane(5, Plane((1.0, 0.0, 0.0), 0.0), ((0.0, 0.0), (0.0, 4.0))),
    ),
    floor_polygon=((0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (2.0, 2.0), (2.0, 4.0), (0.0, 4.0)),
    ceiling_height=2.5,
)


def test_a_wall_overshooting_an_inner_corner_is_trimmed_to_the_room_outline():
    start, end = wall_extent(L_ROOM, L_ROOM.walls[2])
    assert start == pytest.approx([2.0, 2.0], abs=0.006) and end == pytest.approx([4.0, 2.0])
    # walls that end on the room's outline keep their whole segment
    for wall in (L_ROOM.walls[0], L_ROOM.walls[3]):
        assert np.asarray(wall_extent(L_ROOM, wall)) == pytest.approx(np.asarray(wall.segment))
    box = shell_meshes(L_ROOM, ExportConfig())["shell_wall_2"]
    assert box.bounds[0][0] == pytest.approx(2.0, abs=0.006)


def test_a_cabinet_in_the_inner_corner_does_not_start_inside_the_overshooting_wall(tmp_path):
    # a cabinet in the wing, its side against the wall x = 2 and its front at the wing's opening (y = 2)
    cabinet = trimesh.creation.box(bounds=[[1.5, 2.0, 0.0], [1.999, 2.5, 1.0]])
    obj = ExportObject(1, "cabinet", np.asarray(cabinet.vertices), np.asarray(cabinet.faces, np.int64), np.eye(4))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR),))
    config = ExportConfig(decomposition_cache=str(tmp_path / "cache"))
    export_scene(RunPaths(tmp_path).scene, [obj], L_ROOM, graph, [], config)
    check = simcheck_run(tmp_path, SimcheckConfig())
    assert check.summary.penetration_t0_max < 0.002
    assert check.summary.stable == 1
