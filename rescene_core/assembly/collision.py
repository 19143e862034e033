"""Mesh-mesh collision between objects: an rtree broad phase over world AABBs and an fcl narrow phase.

The broad phase (an R*-tree over the objects' world bounding boxes, rebuilt per query) keeps the cost
near-linear in the number of objects; the narrow phase runs python-fcl on BVH models of the asset meshes
(triangle intersection). A pair whose surfaces do not cross is still a collision when one object lies
entirely inside the other; that is tested with trimesh's point containment on closed meshes only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import fcl
import numpy as np
import rtree
import trimesh
from numpy.typing import NDArray

from rescene_core.assembly.objects import AssemblyObject
from rescene_core.geometry.sim3 import apply, inverse, parts_from_sim3
from rescene_core.records import InstanceId

Pair = tuple[InstanceId, InstanceId]


class CollisionWorld:
    """Collision queries over a fixed set of objects at varying poses (world metres)."""

    def __init__(self, objects: dict[InstanceId, AssemblyObject]):
        self.objects = objects
        self._bvh: dict[InstanceId, tuple[float, fcl.BVHModel]] = {}
        self._closed: dict[InstanceId, trimesh.Trimesh | None] = {}

    def _model(self, i: InstanceId, scale: float) -> fcl.BVHModel:
        hit = self._bvh.get(i)
        if hit is None or abs(hit[0] - scale) > 1e-12:
            obj = self.objects[i]
            model = fcl.BVHModel()
            model.beginModel(len(obj.vertices), len(obj.faces))
            model.addSubModel(np.asarray(obj.vertices, np.float64) * scale, np.asarray(obj.faces, np.int64))
            model.endModel()
            hit = (scale, model)
            self._bvh[i] = hit
        return hit[1]

    def _closed_mesh(self, i: InstanceId) -> trimesh.Trimesh | None:
        if i not in self._closed:
            mesh = self.objects[i].mesh()
            self._closed[i] = mesh if mesh.is_watertight else None
        return self._closed[i]

    def fcl_object(self, i: InstanceId, world_from_asset: NDArray) -> fcl.CollisionObject:
        scale, rot, trans = parts_from_sim3(world_from_asset)
        return fcl.CollisionObject(self._model(i, scale), fcl.Transform(rot, trans))

    def _inside(self, a: InstanceId, pose_a: NDArray, b: InstanceId, pose_b: NDArray) -> bool:
        """Whether a vertex of a lies inside closed mesh b."""
        mesh = self._closed_mesh(b)
        if mesh is None:
            return False
        point = apply(pose_a, self.objects[a].vertices[:1])
        return bool(mesh.contains(apply(inverse(pose_b), point))[0])

    def candidate_pairs(self, bounds: dict[InstanceId, NDArray]) -> list[Pair]:
        """Pairs whose world AABBs (each [2, 3]: min, max) overlap, from an rtree index."""
        ids = list(bounds)
        props = rtree.index.Property(dimension=3)
        index = rtree.index.Index(
            ((k, (*bounds[i][0], *bounds[i][1]), None) for k, i in enumerate(ids)), properties=props
        )
        pairs = set()
        for k, i in enumerate(ids):
            for m in index.intersection((*bounds[i][0], *bounds[i][1])):
                if m > k:
                    pairs.add((ids[k], ids[m]))
        return sorted(pairs)

    def colliding_pairs(
        self,
        poses: dict[InstanceId, NDArray],
        skip: Callable[[InstanceId, InstanceId], bool] | None = None,
        only: Iterable[InstanceId] | None = None,
    ) -> list[Pair]:
        """Pairs (a < b) of objects whose meshes intersect at ``poses``; ``skip(a, b)`` drops pairs
        (e.g. parent and child), ``only`` restricts to pairs involving those objects."""
        bounds = {}
        for i, pose in poses.items():
            v = apply(pose, self.objects[i].vertices)
            bounds[i] = np.stack([v.min(axis=0), v.max(axis=0)])
        only_set = None if only is None else set(only)
        objs: dict[InstanceId, fcl.CollisionObject] = {}
        out: list[Pair] = []
        request = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
        for a, b in self.candidate_pairs(bounds):
            a, b = (a, b) if a < b else (b, a)
            if only_set is not None and a not in only_set and b not in only_set:
                continue
            if skip is not None and skip(a, b):
                continue
            for i in (a, b):
                if i not in objs:
                    objs[i] = self.fcl_object(i, poses[i])
            result = fcl.CollisionResult()
            fcl.collide(objs[a], objs[b], request, result)
            if result.is_collision or self._inside(a, poses[a], b, poses[b]) or self._inside(b, poses[b], a, poses[a]):
                out.append((a, b))
        return out
