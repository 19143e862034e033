"""Scene export: ``scene/scene.glb`` (one named node per object plus the room shell), ``scene/scene.json``
(poses, graph, shell, missing instances), one mesh per object under ``scene/objects/`` and surface samples of
the placed objects in ``scene/points.zarr`` (rescene_core/export/points.py).

docs/run-directory.md describes the files. Frames: world metres, z up; object meshes are stored in their
asset frame and placed by ``world_from_asset`` (a Sim(3), float64 [4, 4]).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, cast

import numpy as np
import trimesh

from rescene_core.config import ExportConfig
from rescene_core.export.gltf import ROOT_NODE, object_glb, scene_glb
from rescene_core.export.objects import ExportObject
from rescene_core.export.points import write_scene_points
from rescene_core.export.shell import shell_meshes
from rescene_core.export.simulation import export_simulation
from rescene_core.exported_scene import SCENE_FORMAT, ExportedObject, ExportedScene
from rescene_core.geometry import sim3
from rescene_core.io import hash_file, hash_tree, write_bytes_atomic
from rescene_core.names import check_unique
from rescene_core.records import InstanceId, Missing, RoomShell, Root, SceneGraph, parent_to_json


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
    for e in parents.values():
        if not isinstance(e.parent, Root) and int(e.parent) in names and int(e.child) in names:
            children.setdefault(names[int(e.parent)], []).append(names[int(e.child)])
    out: dict[str, dict[str, Any]] = {}
    for obj in objects:
        edge = parents.get(InstanceId(obj.instance))
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
    ``out_dir``; returns {file: sha256}. Node names come from rescene_core/names.py; the label is
    kept verbatim in scene.json and the node's ``extras``.

    extra: additional top-level fields for scene.json (e.g. the capture and the backends that ran).
    """
    out_dir = Path(out_dir)
    check_unique((o.instance, o.label) for o in objects)
    hashes: dict[str, str] = {}
    entries = []
    parents = graph.parent_of() if graph is not None else {}
    for obj in sorted(objects, key=lambda o: o.instance):
        rel = f"objects/{obj.node_name}.glb"
        write_bytes_atomic(out_dir / rel, object_glb(obj.vertices, obj.faces))
        hashes[rel] = hash_file(out_dir / rel)
        edge = parents.get(InstanceId(obj.instance))
        m = np.asarray(obj.world_from_asset, dtype=np.float64)
        entries.append(
            ExportedObject(
                instance=InstanceId(int(obj.instance)),
                label=obj.label,
                node=obj.node_name,
                mesh=rel,
                world_from_asset=m,
                scale=sim3.scale_of(m),
                registered_world_from_asset=obj.registered_world_from_asset,
                parent=None if edge is None else parent_to_json(edge.parent),
                relation=None if edge is None else edge.relation.value,
                completions=tuple(obj.completions),
            )
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
    exported = ExportedScene(
        objects=tuple(entries),
        graph=graph if graph is not None else SceneGraph(()),
        shell=shell,
        shell_nodes=tuple(sorted(shell_meshes(shell, config))) if shell is not None else (),
        missing=tuple(missing),
        extra=dict(extra or {}),
    )
    exported.write(out_dir / "scene.json")
    hashes["scene.json"] = hash_file(out_dir / "scene.json")
    write_scene_points(out_dir / "points.zarr", list(objects), config)
    hashes["points.zarr"] = hash_tree(out_dir / "points.zarr")
    if config.simulation:
        sim = export_simulation(out_dir, list(objects), shell, graph, missing, config)
        for rel in sim.files:
            hashes[rel] = hash_file(out_dir / rel)
        hashes[sim.mjcf_dir] = hash_tree(out_dir / sim.mjcf_dir)
    return hashes


def read_exported_scene(
    scene_dir: str | Path,
) -> tuple[list[ExportObject], RoomShell | None, SceneGraph, list[Missing], dict[str, Any]]:
    """The objects (meshes loaded), shell, graph, missing instances and other scene.json fields of an
    exported scene/."""
    scene_dir = Path(scene_dir)
    exported = ExportedScene.read(scene_dir / "scene.json")
    objects = []
    for entry in exported.objects:
        # force="mesh" always gives a Trimesh; the stubs type load() as any Geometry
        mesh = cast(trimesh.Trimesh, trimesh.load(scene_dir / entry.mesh, force="mesh", process=False))
        objects.append(
            ExportObject(
                int(entry.instance),
                entry.label,
                np.asarray(mesh.vertices, np.float64),
                np.asarray(mesh.faces, np.int64),
                entry.world_from_asset,
                entry.registered_world_from_asset,
                entry.completions,
            )
        )
    return objects, exported.shell, exported.graph, list(exported.missing), dict(exported.extra)


def export_run(run_dir: str | Path, config: ExportConfig) -> dict[str, Any]:
    """Write a run's scene/ exports again (GLB, scene.json, MJCF, USD, report) from its scene.json and
    objects/; returns {file: sha256}."""
    scene_dir = Path(run_dir) / "scene"
    objects, shell, graph, missing, extra = read_exported_scene(scene_dir)
    return export_scene(scene_dir, objects, shell, graph, missing, config, extra=extra)
