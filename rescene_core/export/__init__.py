"""Exports of an assembled scene (GLB with named nodes, scene.json, per-object meshes, a Zarr point cloud)."""

from rescene_core.export.objects import ExportObject, node_name, placed_objects
from rescene_core.export.points import read_scene_points, write_scene_points
from rescene_core.export.scene import ExportConfig, build_scene, export_scene
from rescene_core.export.shell import shell_meshes

__all__ = [
    "ExportConfig",
    "ExportObject",
    "placed_objects",
    "build_scene",
    "export_scene",
    "node_name",
    "read_scene_points",
    "shell_meshes",
    "write_scene_points",
]
