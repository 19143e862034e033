"""Compile Newton's Warp kernels once, ahead of the first check: ``python -m rescene_core.sim.newton_warm``.

Warp compiles each kernel module the first time it runs (about a minute on 2 cores for what the check uses)
and keeps it in ``~/.cache/warp``; ``make setup`` runs this on a two-box scene so that the first
``rescene simcheck --engine newton`` and the tests do not pay it. Without Newton installed it says so and
exits 0 (Newton is optional).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from rescene_core.config import SimcheckConfig
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane

SMALL_ROOM = RoomShell(
    floor=Plane((0.0, 0.0, 1.0), 0.0),
    walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 1.0), ((-1.0, -1.0), (1.0, -1.0))),),
    floor_polygon=((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)),
    ceiling_height=2.5,
)
"""A 2 x 2 m room with one wall: floor and wall as triangle meshes, like every exported shell."""


def two_box_scene(scene_dir: Path) -> Path:
    """Export a box on the floor and a smaller box on it under ``scene_dir``; returns the USD's path."""
    objects = []
    for instance, extents, z in ((1, (0.4, 0.4, 0.4), 0.2), (2, (0.2, 0.2, 0.2), 0.5)):
        box = trimesh.creation.box(extents)
        pose = sim3.sim3_from_parts(1.0, np.eye(3), np.array([0.0, 0.0, z]))
        objects.append(ExportObject(instance, "box", box.vertices, box.faces, pose))
    graph = SceneGraph(
        (Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR), Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1)))
    )
    export_scene(scene_dir, objects, SMALL_ROOM, graph, [], ExportConfig(decomposition_cache=str(scene_dir / "cache")))
    return scene_dir / "scene.usda"


def warm_kernels() -> float:
    """Run the Newton check 0.05 s on the two-box scene; returns the wall seconds it took."""
    from rescene_core.sim.newton_check import newton_simcheck

    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        newton_simcheck(two_box_scene(Path(tmp) / "scene"), SMALL_ROOM, SimcheckConfig(seconds=0.05))
    return time.perf_counter() - started


def main() -> int:
    from rescene_core.sim.newton_check import NewtonUnavailable

    try:
        seconds = warm_kernels()
    except NewtonUnavailable as err:
        print(f"Newton kernels not compiled: {err}")
        return 0
    print(f"Newton's Warp kernels are compiled and cached ({seconds:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
