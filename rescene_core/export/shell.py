"""The room shell as meshes for the exports (floor slab, wall boxes; the solids come from
``rescene_core.geometry.room``): scene.py (GLB) and usd.py use them."""

from __future__ import annotations

import trimesh
from shapely.geometry import Polygon

from rescene_core.config import ExportConfig
from rescene_core.geometry.room import floor_height, wall_boxes
from rescene_core.records import RoomShell


def shell_meshes(shell: RoomShell, config: ExportConfig) -> dict[str, trimesh.Trimesh]:
    """Floor slab (the floor polygon extruded downwards) and one box per wall segment (trimmed to the room's
    outline, ``wall_extent``), world frame."""

    out: dict[str, trimesh.Trimesh] = {}
    z0 = floor_height(shell)
    poly = Polygon(shell.floor_polygon)
    if poly.is_valid and poly.area > 0:
        slab = trimesh.creation.extrude_polygon(poly, config.floor_thickness)
        slab.apply_translation([0.0, 0.0, z0 - config.floor_thickness])
        out["shell_floor"] = slab
    height = shell.ceiling_height if shell.ceiling_height else config.wall_height
    for wall_id, centre, yaw, length in wall_boxes(shell, config.wall_thickness, height):
        box = trimesh.creation.box(extents=[length, config.wall_thickness, height])
        world_from_box = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
        world_from_box[:3, 3] = centre
        box.apply_transform(world_from_box)
        out[f"shell_wall_{wall_id}"] = box
    return out
