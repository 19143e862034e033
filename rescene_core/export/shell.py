"""The room shell as static geometry for the exports (floor slab, wall boxes), below every exporter:
scene.py (GLB), mjcf.py, usd.py and the physics check use it."""

from __future__ import annotations

import numpy as np
import trimesh

from rescene_core.config import ExportConfig
from rescene_core.records import RoomShell


def floor_height(shell: RoomShell) -> float:
    """Height of the floor plane at the origin (m), from ``normal . x + offset = 0``."""
    nz = shell.floor.normal[2]
    return float(-shell.floor.offset / nz) if abs(nz) > 1e-9 else 0.0


def shell_meshes(shell: RoomShell, config: ExportConfig) -> dict[str, trimesh.Trimesh]:
    """Floor slab (the floor polygon extruded downwards) and one box per wall segment, world frame."""
    from shapely.geometry import Polygon

    out: dict[str, trimesh.Trimesh] = {}
    z0 = floor_height(shell)
    poly = Polygon(shell.floor_polygon)
    if poly.is_valid and poly.area > 0:
        slab = trimesh.creation.extrude_polygon(poly, config.floor_thickness)
        slab.apply_translation([0.0, 0.0, z0 - config.floor_thickness])
        out["shell_floor"] = slab
    height = shell.ceiling_height if shell.ceiling_height else config.wall_height
    for wall in shell.walls:
        (x0, y0), (x1, y1) = wall.segment
        length = float(np.hypot(x1 - x0, y1 - y0))
        if length <= 0:
            continue
        box = trimesh.creation.box(extents=[length, config.wall_thickness, height])
        yaw = float(np.arctan2(y1 - y0, x1 - x0))
        normal = np.asarray(wall.plane.normal, dtype=np.float64)
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, z0 + height / 2]) - normal * config.wall_thickness / 2
        world_from_box = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
        world_from_box[:3, 3] = centre
        box.apply_transform(world_from_box)
        out[f"shell_wall_{wall.id}"] = box
    return out
