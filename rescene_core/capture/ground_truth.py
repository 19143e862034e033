"""Ground truth of a synthetic capture: object meshes and poses, support relations, the room shell.

It lives in the capture's ``gt/`` group (written by ``write_ground_truth``, read by ``read_ground_truth``):

    gt/attrs            format="rescene-gt", version, objects (JSON list), relations (JSON list),
                        shell (RoomShell JSON), structure (JSON list: {instance_id, kind, wall_id})
    gt/vertices         float64 [V, 3]  every object's vertices in its canonical frame, concatenated
    gt/faces            int64   [F, 3]  every object's faces, indices local to the object, concatenated
    gt/vertex_offsets   int64   [N + 1] CSR offsets into vertices, one row per object (attrs order)
    gt/face_offsets     int64   [N + 1] CSR offsets into faces
    gt/object_id        int32   [T, H, W] optional: the object id seen at each pixel (0 = structure or
                        nothing), rendered without any of the capture's errors

Object ids are their own id space (1..N); they are *not* capture instance ids. ``GtObject.instance_ids``
says which capture instance ids show the object: the first is its primary (largest) instance; two ids
when the capture split the object, none when the capture missed it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import zarr
from numpy.typing import NDArray

from rescene_core.capture.format import write_array
from rescene_core.records import Edge, InstanceId, Relation, RoomShell, Root, SceneGraph

GT_FORMAT = "rescene-gt"
GT_VERSION = 1


@dataclass(frozen=True)
class GtObject:
    """One ground-truth object.

    vertices: float64 [v, 3] in the object's canonical frame (metres; origin = centre of the bottom face
        of its bounding box, z up, the object's front faces +y, its back is at min y).
    faces: int64 [f, 3] triangle indices into ``vertices`` (a closed, watertight surface).
    world_from_object: float64 [4, 4] rigid transform (no scale) from the canonical frame to the world.
    instance_ids: capture instance ids of this object, primary (largest) first; () when missed.
    """

    object_id: int
    label: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    world_from_object: NDArray[np.float64]
    instance_ids: tuple[int, ...] = ()

    def world_vertices(self) -> NDArray[np.float64]:
        """Vertices in the world frame, float64 [v, 3], metres."""
        return self.vertices @ self.world_from_object[:3, :3].T + self.world_from_object[:3, 3]

    def to_json(self) -> dict[str, Any]:
        return {
            "object_id": int(self.object_id),
            "label": self.label,
            "world_from_object": np.asarray(self.world_from_object, dtype=np.float64).tolist(),
            "instance_ids": [int(i) for i in self.instance_ids],
        }


@dataclass(frozen=True)
class GtRelation:
    """Ground-truth support of ``child`` (an object id): on the floor, a wall (``wall_id``) or another object."""

    child: int
    relation: Relation
    parent: int | Root
    wall_id: int | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "child": int(self.child),
            "relation": self.relation.value,
            "parent": self.parent.value if isinstance(self.parent, Root) else int(self.parent),
            "wall_id": None if self.wall_id is None else int(self.wall_id),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> GtRelation:
        parent = d["parent"]
        return cls(
            child=int(d["child"]),
            relation=Relation(d["relation"]),
            parent=Root(parent) if isinstance(parent, str) else int(parent),
            wall_id=None if d.get("wall_id") is None else int(d["wall_id"]),
        )


@dataclass(frozen=True)
class GtStructure:
    """A structural capture instance: ``kind`` is 'floor', 'wall' or 'ceiling'; ``wall_id`` names the wall."""

    instance_id: int
    kind: str
    wall_id: int | None = None

    def to_json(self) -> dict[str, Any]:
        return {"instance_id": int(self.instance_id), "kind": self.kind, "wall_id": self.wall_id}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> GtStructure:
        return cls(int(d["instance_id"]), str(d["kind"]), None if d.get("wall_id") is None else int(d["wall_id"]))


@dataclass(frozen=True)
class GroundTruth:
    """Everything known about a synthetic scene: objects, their supports, and the room shell.

    structure: the structural capture instances (floor, one per wall plane, ceiling).
    """

    objects: tuple[GtObject, ...]
    relations: tuple[GtRelation, ...]
    shell: RoomShell
    structure: tuple[GtStructure, ...] = ()

    def object(self, object_id: int) -> GtObject:
        for obj in self.objects:
            if obj.object_id == object_id:
                return obj
        raise KeyError(f"object {object_id} is not in the ground truth")

    def object_of_instance(self) -> dict[int, int]:
        """Capture instance id -> object id, for every instance that shows an object (structure excluded)."""
        return {int(i): obj.object_id for obj in self.objects for i in obj.instance_ids}

    def primary_instance(self) -> dict[int, int]:
        """Object id -> its primary (largest) capture instance id, for objects the capture did not miss."""
        return {obj.object_id: int(obj.instance_ids[0]) for obj in self.objects if obj.instance_ids}

    def graph_by_instance(self) -> SceneGraph:
        """The ground-truth relations over capture instance ids (each object's primary instance).

        An object the capture missed has no instance: its own edge is dropped, and so are the edges of
        everything it (transitively) supports, so the result is a valid forest. Confidence is 1.
        """
        primary = self.primary_instance()
        by_child = {r.child: r for r in self.relations}

        def reachable(obj_id: int, seen: frozenset[int] = frozenset()) -> bool:
            rel = by_child.get(obj_id)
            if obj_id not in primary or rel is None or obj_id in seen:
                return False
            if isinstance(rel.parent, Root):
                return True
            return reachable(int(rel.parent), seen | {obj_id})

        edges = []
        for rel in self.relations:
            if not reachable(rel.child):
                continue
            parent = rel.parent if isinstance(rel.parent, Root) else InstanceId(primary[int(rel.parent)])
            edges.append(
                Edge(
                    child=InstanceId(primary[rel.child]),
                    relation=rel.relation,
                    parent=parent,
                    confidence=1.0,
                    wall_id=rel.wall_id,
                )
            )
        return SceneGraph(tuple(edges))

    def world_mesh(self, object_id: int):
        """The object's mesh in the world frame as a ``trimesh.Trimesh`` (metres)."""

        obj = self.object(object_id)
        return trimesh.Trimesh(obj.world_vertices(), np.asarray(obj.faces, dtype=np.int64), process=False)


def write_ground_truth(group: zarr.Group, gt: GroundTruth, object_id_frames: NDArray[np.int32] | None = None) -> None:
    """Write ``gt`` as the ``gt/`` subgroup of the capture root ``group``.

    object_id_frames: optional int32 [T, H, W], the error-free object id per pixel (0 = none).
    """

    g = group.create_group("gt")
    vert_counts = [len(o.vertices) for o in gt.objects]
    face_counts = [len(o.faces) for o in gt.objects]
    g.attrs.update(
        {
            "format": GT_FORMAT,
            "version": GT_VERSION,
            "objects": [o.to_json() for o in gt.objects],
            "relations": [r.to_json() for r in gt.relations],
            "shell": gt.shell.to_json(),
            "structure": [s.to_json() for s in gt.structure],
        }
    )
    verts = (
        np.concatenate([np.asarray(o.vertices, np.float64).reshape(-1, 3) for o in gt.objects])
        if gt.objects
        else np.zeros((0, 3))
    )
    faces = (
        np.concatenate([np.asarray(o.faces, np.int64).reshape(-1, 3) for o in gt.objects])
        if gt.objects
        else np.zeros((0, 3), np.int64)
    )
    write_array(g, "vertices", verts.astype(np.float64))
    write_array(g, "faces", faces.astype(np.int64))
    write_array(g, "vertex_offsets", np.concatenate([[0], np.cumsum(vert_counts)]).astype(np.int64))
    write_array(g, "face_offsets", np.concatenate([[0], np.cumsum(face_counts)]).astype(np.int64))
    if object_id_frames is not None:
        t, h, w = object_id_frames.shape
        write_array(g, "object_id", np.asarray(object_id_frames, np.int32), (1, h, w))


def read_ground_truth(capture: Any) -> GroundTruth | None:
    """The ground truth of a capture (a ``Capture``, a zarr group or a path), or None when it has none."""
    if isinstance(capture, str | Path):
        root = zarr.open_group(str(capture), mode="r")
    elif isinstance(capture, zarr.Group):
        root = capture
    else:
        root = capture.root
    if "gt" not in root:
        return None
    g = root["gt"]
    attrs = dict(g.attrs)
    if attrs.get("format") != GT_FORMAT:
        raise ValueError(f"gt/ attrs.format is {attrs.get('format')!r}, expected {GT_FORMAT!r}")
    verts = np.asarray(g["vertices"][...], dtype=np.float64)
    faces = np.asarray(g["faces"][...], dtype=np.int64)
    voff = np.asarray(g["vertex_offsets"][...])
    foff = np.asarray(g["face_offsets"][...])
    objects = []
    for k, d in enumerate(attrs["objects"]):
        objects.append(
            GtObject(
                object_id=int(d["object_id"]),
                label=str(d["label"]),
                vertices=verts[voff[k] : voff[k + 1]],
                faces=faces[foff[k] : foff[k + 1]],
                world_from_object=np.asarray(d["world_from_object"], dtype=np.float64),
                instance_ids=tuple(int(i) for i in d["instance_ids"]),
            )
        )
    return GroundTruth(
        objects=tuple(objects),
        relations=tuple(GtRelation.from_json(r) for r in attrs["relations"]),
        shell=RoomShell.from_json(attrs["shell"]),
        structure=tuple(GtStructure.from_json(s) for s in attrs.get("structure", [])),
    )


def read_object_id_frames(capture: Any) -> zarr.Array | None:
    """The error-free object id per pixel, int32 [T, H, W] zarr array (0 = none), when the capture has it."""
    root = capture.root if hasattr(capture, "root") else zarr.open_group(str(capture), mode="r")
    if "gt" in root and "object_id" in root["gt"]:
        return root["gt"]["object_id"]
    return None
