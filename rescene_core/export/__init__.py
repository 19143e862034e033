"""Exports of an assembled scene (GLB with named nodes, scene.json, per-object meshes)."""

from rescene_core.export.scene import ExportConfig, ExportObject, build_scene, export_scene, node_name, shell_meshes

__all__ = ["ExportConfig", "ExportObject", "build_scene", "export_scene", "node_name", "shell_meshes"]
