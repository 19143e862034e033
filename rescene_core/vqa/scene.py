"""The structured scene the VQA generator reads: objects (label, world mesh, box), scene graph, room shell.

A ``VqaScene`` is read from an assembled run directory (``read_run``), built from ground truth
(``scene_from_ground_truth``), or put together from records directly (``VqaScene(...)``,
``VqaObject.from_mesh``, ``VqaObject.box``). Frames: world metres, z up.
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core import paths
from rescene_core.assets import load_asset
from rescene_core.capture.synth.layout import furnish, random_room
from rescene_core.capture.synth.presets import get_preset
from rescene_core.exported_scene import ExportedScene
from rescene_core.geometry import sim3
from rescene_core.paths import RunPaths
from rescene_core.records import Edge, InstanceId, Layout, Relation, RoomShell, Root, SceneGraph


class VqaInputError(ValueError):
    """The run directory or the records cannot be turned into a VQA scene (the message says why)."""


@dataclass(frozen=True)
class VqaObject:
    """One placed object.

    id: canonical instance id. label: category label.
    vertices: float64 [v, 3] world frame, metres (the final, attached pose applied). faces: int64 [f, 3].
    box_min, box_max: float64 [3], the world-space axis-aligned bounding box (m).
    """

    id: int
    label: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    box_min: NDArray[np.float64]
    box_max: NDArray[np.float64]

    @property
    def center(self) -> NDArray[np.float64]:
        """Centre of the world box, float64 [3] (m)."""
        return (self.box_min + self.box_max) / 2.0

    @property
    def size(self) -> NDArray[np.float64]:
        """Extent of the world box along x, y, z, float64 [3] (m)."""
        return self.box_max - self.box_min

    @classmethod
    def from_mesh(cls, id: int, label: str, vertices_world: NDArray, faces: NDArray) -> VqaObject:
        """An object from a world-frame mesh (vertices [v, 3] metres, faces [f, 3])."""
        v = np.asarray(vertices_world, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if len(v) == 0 or len(f) == 0:
            raise VqaInputError(f"object {id} ({label!r}) has an empty mesh")
        if not np.isfinite(v).all():
            raise VqaInputError(f"object {id} ({label!r}) has non-finite vertices")
        return cls(int(id), str(label), v, f, v.min(axis=0), v.max(axis=0))

    @classmethod
    def box(cls, id: int, label: str, center: NDArray | tuple, size: NDArray | tuple) -> VqaObject:
        """An axis-aligned box object: centre [3] and extent [3] in metres, world frame."""

        mesh = trimesh.creation.box(extents=np.asarray(size, dtype=np.float64))
        mesh.apply_translation(np.asarray(center, dtype=np.float64))
        return cls.from_mesh(id, label, mesh.vertices, mesh.faces)

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "label": self.label,
            "center": self.center.tolist(),
            "box_min": self.box_min.tolist(),
            "box_max": self.box_max.tolist(),
        }


@dataclass(frozen=True)
class VqaScene:
    """Objects, the fused scene graph over their ids, and the room shell.

    Edges whose child or (instance) parent is not among the objects are kept in ``graph`` but ignored by
    ``edges`` (a missing object cannot be asked about).
    """

    objects: tuple[VqaObject, ...]
    graph: SceneGraph
    shell: RoomShell
    scene_id: str = ""
    source: str = "records"
    missing_graph: str | None = None
    """Why the run had no usable scene graph (relation questions are then skipped and counted), else None."""
    missing_instances: tuple[tuple[int, str], ...] = ()
    """Instances placed in the layout that could not be read (id, reason); they are not asked about."""

    def __post_init__(self) -> None:
        if not self.objects:
            raise VqaInputError("the scene has no placed objects: nothing to ask about")
        ids = [o.id for o in self.objects]
        if len(set(ids)) != len(ids):
            dup = sorted(i for i, n in Counter(ids).items() if n > 1)
            raise VqaInputError(f"object ids repeat: {dup}")
        if len(self.shell.floor_polygon) < 3:
            raise VqaInputError("the room shell has no floor polygon (fewer than 3 vertices)")

    def object(self, id: int) -> VqaObject:
        for o in self.objects:
            if o.id == int(id):
                return o
        raise KeyError(f"no object {id}")

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(sorted(o.id for o in self.objects))

    def label_counts(self) -> Counter:
        return Counter(o.label for o in self.objects)

    def edges(self) -> dict[int, Edge]:
        """Edge into each object whose parent is a root or another object of the scene, by child id."""
        have = {o.id for o in self.objects}
        out: dict[int, Edge] = {}
        for e in self.graph.edges:
            if int(e.child) not in have:
                continue
            if not isinstance(e.parent, Root) and int(e.parent) not in have:
                continue
            out[int(e.child)] = e
        return out

    def dangling_edges(self) -> list[Edge]:
        """Edges whose child or (instance) parent is not among the objects (a missing instance)."""
        have = {o.id for o in self.objects}
        return [
            e
            for e in self.graph.edges
            if int(e.child) not in have or (not isinstance(e.parent, Root) and int(e.parent) not in have)
        ]

    def skipped_json(self) -> dict[str, Any]:
        """What could not be asked about and why: the missing graph, unreadable instances, dangling edges."""
        return {
            "graph": self.missing_graph,
            "instances": [{"instance": i, "reason": r} for i, r in self.missing_instances],
            "edges_to_missing_instances": len(self.dangling_edges()),
        }

    def floor_height(self) -> float:
        """Height of the floor plane at the origin (m)."""
        nz = self.shell.floor.normal[2]
        return float(-self.shell.floor.offset / nz) if abs(nz) > 1e-9 else 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "scene_id": self.scene_id,
            "source": self.source,
            "objects": [o.to_json() for o in self.objects],
            "graph": self.graph.to_json(),
            "shell": self.shell.to_json(),
        }


def _read(path: Path, what: str) -> Any:

    if not path.is_file():
        raise VqaInputError(f"{path}: missing ({what}); is this an assembled run directory (`rescene run`)?")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise VqaInputError(f"{path}: not valid JSON ({err})") from err


def _labels(run: RunPaths) -> dict[int, str]:
    """Instance labels from scene/scene.json, else manifest.json, else instances/<id>/asset.json metadata."""
    if run.scene_json.is_file():
        try:
            scene = ExportedScene.from_json(_read(run.scene_json, "exported scene"), str(run.scene_json))
        except (KeyError, TypeError, ValueError) as err:
            raise VqaInputError(f"{run.scene_json}: not an exported scene ({err})") from err
        return {int(o.instance): o.label for o in scene.objects}
    if run.manifest.is_file():
        rows = _read(run.manifest, "run manifest").get("instances", [])
        return {int(r["instance"]): str(r["label"]) for r in rows if "label" in r}
    out: dict[int, str] = {}
    for asset_json in sorted(run.instances.glob(f"*/{Path(paths.ASSET_META).name}")):
        label = _read(asset_json, "asset metadata").get("metadata", {}).get("label")
        if label is not None:
            out[int(asset_json.parent.name)] = str(label)
    return out


def read_run(run_dir: str | Path) -> VqaScene:
    """Read an assembled run directory into a ``VqaScene``.

    Reads RUN/shell.json (room shell), RUN/scenegraph/graph.json (fused graph), RUN/layout.json (final
    world_from_asset per instance) and RUN/instances/<id>/asset.glb (asset-frame meshes); labels come from
    RUN/scene/scene.json (or manifest.json). Raises ``VqaInputError`` naming the missing or broken file.
    """

    run = RunPaths(run_dir)
    if not run.root.is_dir():
        raise VqaInputError(f"{run.root}: not a directory (expected a run directory written by `rescene run`)")
    shell = RoomShell.from_json(_read(run.shell, "room shell"))
    graph_path = run.graph
    missing_graph = None
    if graph_path.is_file():
        graph = SceneGraph.from_json(_read(graph_path, "fused scene graph"))
    else:
        graph, missing_graph = SceneGraph(()), f"{graph_path}: missing (the scene-graph stage did not finish)"
    layout = Layout.from_json(_read(run.layout, "attachment layout"))
    labels = _labels(run)
    objects = []
    missing: list[tuple[int, str]] = []
    for inst, world_from_asset in sorted(layout.world_from_asset.items()):
        glb = run.asset_glb(inst)
        if run.asset_meta(inst).is_file():
            glb = run.instance_dir(inst) / _read(run.asset_meta(inst), "asset metadata").get("glb", glb.name)
        if not glb.is_file():
            missing.append((int(inst), f"{glb}: missing asset mesh"))
            continue
        if int(inst) not in labels:
            missing.append((int(inst), f"no label in {paths.SCENE_JSON} or {paths.MANIFEST}"))
            continue
        asset = load_asset(glb, int(inst))
        verts = sim3.apply(np.asarray(world_from_asset, np.float64), asset.vertices)
        objects.append(VqaObject.from_mesh(int(inst), labels[int(inst)], verts, asset.faces))
    scene_id = ""
    if run.scene_json.is_file():
        scene_id = str(_read(run.scene_json, "exported scene").get("scene_id", ""))
    if not objects:
        raise VqaInputError(f"{run.layout}: no placed objects, nothing to ask about")
    return VqaScene(
        tuple(objects),
        graph,
        shell,
        scene_id=scene_id,
        source=str(run.root),
        missing_graph=missing_graph,
        missing_instances=tuple(missing),
    )


def scene_from_ground_truth(gt) -> VqaScene:
    """A ``VqaScene`` from a synthetic capture's ``GroundTruth``: ids are each object's primary capture
    instance (objects the capture missed are left out), edges have confidence 1."""
    primary = gt.primary_instance()
    objects = []
    for obj in gt.objects:
        if obj.object_id not in primary:
            continue
        objects.append(VqaObject.from_mesh(primary[obj.object_id], obj.label, obj.world_vertices(), obj.faces))
    return VqaScene(tuple(objects), gt.graph_by_instance(), gt.shell, source="ground-truth")


def scene_from_synth_layout(preset: str = "standard", seed: int = 0) -> VqaScene:
    """The ground-truth ``VqaScene`` of the synthetic capture ``(preset, seed)`` without rendering its frames.

    It draws the room and furniture exactly as ``rescene_core.capture.synth.make_scene`` does (the same
    seeded stream), so objects, labels, poses, relations and shell are the capture's ground truth; ids are
    the generator's object ids (not capture instance ids) and no object is missed. Edges have confidence 1.
    Use ``scene_from_ground_truth`` to get capture instance ids from a written capture.
    """

    cfg = get_preset(preset)
    # default_rng(seed) seeds from SeedSequence(seed): its first child is make_scene's layout stream
    rng_layout = np.random.default_rng(np.random.SeedSequence(seed).spawn(6)[0])
    room = random_room(rng_layout, cfg)
    lay = furnish(room, cfg, rng_layout)
    objects = []
    edges = []
    for obj in lay.objects:
        verts, faces = obj.model.union_mesh()
        world = verts @ obj.world_from_object[:3, :3].T + obj.world_from_object[:3, 3]
        objects.append(VqaObject.from_mesh(obj.object_id, obj.label, world, faces))
        parent = obj.parent if isinstance(obj.parent, Root) else InstanceId(int(obj.parent))
        edges.append(Edge(InstanceId(obj.object_id), obj.relation, parent, 1.0, wall_id=obj.wall_id))
    return VqaScene(
        tuple(objects),
        SceneGraph(tuple(edges)),
        room.shell(),
        scene_id=f"synth-{cfg.name}-{seed}",
        source="synth-layout",
    )


def edge_parent_id(edge: Edge) -> int | None:
    """The parent instance id of an edge, or None when the parent is the floor or a wall."""
    return None if isinstance(edge.parent, Root) else int(edge.parent)


def rests_on(edge: Edge) -> bool:
    return edge.relation == Relation.RESTS_ON


__all__ = [
    "InstanceId",
    "VqaInputError",
    "VqaObject",
    "VqaScene",
    "edge_parent_id",
    "read_run",
    "rests_on",
    "scene_from_ground_truth",
    "scene_from_synth_layout",
]
