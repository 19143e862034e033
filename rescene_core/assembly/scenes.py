"""Small hand-built scenes for the tests and the scaling benchmark: a rectangular room and boxes.

Box assets follow the ground-truth canonical frame: metres, origin at the centre of the bottom face, z up,
front towards +y (the back is the face at min y).
"""

from __future__ import annotations

import numpy as np
import trimesh

from rescene_core.assembly.objects import AssemblyObject
from rescene_core.assembly.transforms import rotation_about, translation
from rescene_core.records import Edge, InstanceId, Plane, Relation, RoomShell, Root, SceneGraph, WallPlane


def rect_room(width: float = 4.0, depth: float = 5.0, height: float = 2.6) -> RoomShell:
    """Room [0, width] x [0, depth] with floor z = 0 and four walls, ids 0 (y=0), 1 (x=w), 2 (y=d), 3 (x=0)."""
    corners = [(0.0, 0.0), (width, 0.0), (width, depth), (0.0, depth)]
    normals = [(0.0, 1.0), (-1.0, 0.0), (0.0, -1.0), (1.0, 0.0)]
    walls = []
    for k in range(4):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
        nx, ny = normals[k]
        walls.append(WallPlane(k, Plane((nx, ny, 0.0), -(nx * x0 + ny * y0)), ((x0, y0), (x1, y1))))
    return RoomShell(Plane((0.0, 0.0, 1.0), 0.0), tuple(walls), tuple(corners), height)


def box_asset(extents: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Closed box mesh (vertices [8, 3], faces [12, 3]) of ``extents`` (x, y, z) m, bottom-centre origin."""
    box = trimesh.creation.box(extents=extents)
    box.apply_translation([0.0, 0.0, extents[2] / 2.0])
    return np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64)


def placed(x: float, y: float, z: float = 0.0, yaw_deg: float = 0.0) -> np.ndarray:
    """world_from_asset [4, 4]: yaw about z, then the asset origin at (x, y, z)."""
    return translation([x, y, z]) @ rotation_about([0.0, 0.0, np.radians(yaw_deg)], [0.0, 0.0, 0.0])


def box_object(instance: int, label: str, extents, world_from_asset, exact_shape: bool = True) -> AssemblyObject:
    """A box of ``extents`` (m) whose asset frame is its own (an exact shape unless told otherwise)."""
    v, f = box_asset(extents)
    return AssemblyObject(InstanceId(instance), label, v, f, np.asarray(world_from_asset, np.float64), exact_shape)


def bedroom() -> tuple[dict[InstanceId, AssemblyObject], SceneGraph, RoomShell]:
    """A bed against the north wall, a nightstand with a lamp, two pictures on the north wall, a wardrobe
    in the south-east corner: the ground-truth layout (everything in contact, nothing colliding)."""
    shell = rect_room()
    objs = [
        box_object(1, "bed", (1.6, 2.0, 0.5), placed(2.0, 4.0, 0.0, 180.0)),
        box_object(2, "nightstand", (0.5, 0.4, 0.55), placed(0.6, 4.78, 0.0, 180.0)),
        box_object(3, "lamp", (0.2, 0.2, 0.4), placed(0.6, 4.78, 0.55, 180.0)),
        box_object(4, "picture", (0.6, 0.03, 0.5), placed(1.6, 4.985, 1.2, 180.0)),
        box_object(5, "picture", (0.6, 0.03, 0.5), placed(2.6, 4.985, 1.2, 180.0)),
        box_object(6, "wardrobe", (1.0, 0.6, 2.0), placed(3.5, 0.3, 0.0, 0.0)),
    ]
    edges = (
        Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR),
        Edge(InstanceId(2), Relation.RESTS_ON, Root.FLOOR),
        Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(2)),
        Edge(InstanceId(4), Relation.MOUNTS_ON, Root.WALL),
        Edge(InstanceId(5), Relation.MOUNTS_ON, Root.WALL),
        Edge(InstanceId(6), Relation.RESTS_ON, Root.FLOOR),
    )
    return {o.instance: o for o in objs}, SceneGraph(edges), shell


def grid_scene(count: int, spacing: float = 1.2, seed: int = 0):
    """``count`` floor boxes on a grid in a square room sized to hold them, each perturbed (floating or
    sunk up to 0.2 m, a few degrees of tilt), for timing the solver's scaling."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(count)))
    shell = rect_room(side * spacing, side * spacing)
    objs, edges = {}, []
    for k in range(count):
        cx, cy = (k % side + 0.5) * spacing, (k // side + 0.5) * spacing
        ext = tuple(rng.uniform([0.4, 0.4, 0.4], [0.9, 0.9, 1.0]))
        pose = placed(cx, cy, rng.uniform(-0.2, 0.2), rng.uniform(-30, 30))
        tilt = rotation_about(rng.normal(size=3) * np.radians(3.0) * np.array([1, 1, 0]), [cx, cy, 0.0])
        o = box_object(k + 1, "box", ext, tilt @ pose)
        objs[o.instance] = o
        edges.append(Edge(o.instance, Relation.RESTS_ON, Root.FLOOR))
    return objs, SceneGraph(tuple(edges)), shell
