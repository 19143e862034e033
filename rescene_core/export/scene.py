"""Scene export: ``scene/scene.glb`` (one named node per object plus the room shell), ``scene/scene.json``
(poses, graph, shell, missing instances), one mesh per object under ``scene/objects/`` and surface samples of
the placed objects in ``scene/points.zarr`` (rescene_core/export/points.py).

docs/run-directory.md describes the files. Frames: world metres, z up; object meshes are stored in their
asset frame and placed by ``world_from_asset`` (a Sim(3), float64 [4, 4]).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from rescene_core.config import ExportConfig
from rescene_core.export.gltf import ROOT_NODE, object_glb, scene_glb
from rescene_core.export.objects import ExportObject
from rescene_core.export.points import write_scene_points
from rescene_core.geometry import sim3
from rescene_core.io import hash_file, hash_tree, write_bytes_atomic
from rescene_core.records import Missing, RoomShell, Root, SceneGraph, parent_to_json

SCENE_FORMAT = "rescene-scene"
SCENE_VERSION = 1


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


def build_scene(objects: Iterable[ExportObject], shell: RoomShell | None, config: ExportConfig) -> trimesh.Scene:
    """A trimesh Scene: one node per object (mesh in the asset frame, node transform world_from_asset)
    plus the shell meshes (already in the world frame)."""
    scene = trimesh.Scene()
    for obj in objects:
        mesh = trimesh.Trimesh(np.asarray(obj.vertices), np.asarray(obj.faces), process=False)
        scene.add_geometry(
            mesh, node_name=obj.node_name, geom_name=obj.node_name, transform=np.asarray(obj.world_from_asset)
        )
    if shell is not None:
        for name, mesh in shell_meshes(shell, config).items():
            scene.add_geometry(mesh, node_name=name, geom_name=name)
    return scene


def node_extras(
    objects: Iterable[ExportObject], shell: RoomShell | None, graph: SceneGraph | None, config: ExportConfig
) -> dict[str, dict[str, Any]]:
    """glTF node ``extras`` by node name: each object's id, label and scene-graph edge (relation, parent,
    confidence, wall), its children; each shell node's kind."""
    parents = graph.parent_of() if graph is not None else {}
    names = {int(o.instance): o.node_name for o in objects}
    children: dict[str, list[str]] = {}
    for edge in parents.values():
        if not isinstance(edge.parent, Root) and int(edge.parent) in names and int(edge.child) in names:
            children.setdefault(names[int(edge.parent)], []).append(names[int(edge.child)])
    out: dict[str, dict[str, Any]] = {}
    for obj in objects:
        edge = parents.get(obj.instance)
        out[obj.node_name] = {
            "instance": int(obj.instance),
            "label": obj.label,
            "relation": None if edge is None else edge.relation.value,
            "parent": None if edge is None else parent_to_json(edge.parent),
            "parent_node": None if edge is None or isinstance(edge.parent, Root) else names.get(int(edge.parent), None),
            "confidence": None if edge is None else float(edge.confidence),
            "wall_id": None if edge is None else edge.wall_id,
            "children": sorted(children.get(obj.node_name, [])),
        }
    if shell is not None:
        for name in shell_meshes(shell, config):
            kind = "floor" if name == "shell_floor" else "wall"
            out[name] = {"shell": kind, **({"wall_id": int(name.rsplit("_", 1)[1])} if kind == "wall" else {})}
    return out


def export_scene(
    out_dir: str | Path,
    objects: list[ExportObject],
    shell: RoomShell | None,
    graph: SceneGraph | None,
    missing: Iterable[Missing],
    config: ExportConfig,
    extra: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Write scene.glb (+Y up, see rescene_core/export/gltf.py), scene.json and objects/<node>.glb under
    ``out_dir``; returns {file: sha256}.

    extra: additional top-level fields for scene.json (e.g. the capture and the backends that ran).
    """
    out_dir = Path(out_dir)
    hashes: dict[str, str] = {}
    entries = []
    parents = graph.parent_of() if graph is not None else {}
    for obj in sorted(objects, key=lambda o: o.instance):
        rel = f"objects/{obj.node_name}.glb"
        write_bytes_atomic(out_dir / rel, object_glb(obj.vertices, obj.faces))
        hashes[rel] = hash_file(out_dir / rel)
        edge = parents.get(obj.instance)
        m = np.asarray(obj.world_from_asset, dtype=np.float64)
        entries.append(
            {
                "instance": int(obj.instance),
                "label": obj.label,
                "node": obj.node_name,
                "mesh": rel,
                "world_from_asset": m.tolist(),
                "scale": sim3.scale_of(m),
                "registered_world_from_asset": None
                if obj.registered_world_from_asset is None
                else np.asarray(obj.registered_world_from_asset).tolist(),
                "parent": None if edge is None else edge.to_json()["parent"],
                "relation": None if edge is None else edge.relation.value,
            }
        )
    missing = list(missing)
    write_bytes_atomic(
        out_dir / "scene.glb",
        scene_glb(
            build_scene(objects, shell, config),
            node_extras(objects, shell, graph, config),
            {"format": SCENE_FORMAT, "world_up": "+z", "root_node": ROOT_NODE, "units": "m"},
        ),
    )
    hashes["scene.glb"] = hash_file(out_dir / "scene.glb")
    doc = {
        "format": SCENE_FORMAT,
        "version": SCENE_VERSION,
        "units": "m",
        "up": "+z",
        "objects": entries,
        "graph": graph.to_json() if graph is not None else {"edges": []},
        "shell": shell.to_json() if shell is not None else None,
        "shell_nodes": sorted(shell_meshes(shell, config)) if shell is not None else [],
        "missing": [m.to_json() for m in missing],
        **(extra or {}),
    }
    write_bytes_atomic(out_dir / "scene.json", json.dumps(doc, indent=2).encode())
    hashes["scene.json"] = hash_file(out_dir / "scene.json")
    write_scene_points(out_dir / "points.zarr", list(objects), config)
    hashes["points.zarr"] = hash_tree(out_dir / "points.zarr")
    if config.simulation:
        from rescene_core.export.simulation import MJCF_DIR, export_simulation

        sim = export_simulation(out_dir, list(objects), shell, graph, missing, config)
        for rel in sim.files:
            hashes[rel] = hash_file(out_dir / rel)
        hashes[MJCF_DIR] = hash_tree(out_dir / MJCF_DIR)
    return hashes
