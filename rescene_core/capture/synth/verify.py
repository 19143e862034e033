"""Geometric checks of a ground truth: every relation is physically true, nothing interpenetrates.

Used by the tests and by anyone who builds ground truth another way. Distances in metres, volumes in m^3.
"""

from __future__ import annotations

import itertools

import manifold3d
import numpy as np
from shapely.geometry import Point

from rescene_core.capture.ground_truth import GroundTruth
from rescene_core.records import Relation, Root


def _solid(vertices, faces) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh(vert_properties=np.asarray(vertices, np.float32), tri_verts=np.asarray(faces, np.uint32))
    )


def mesh_distance(gt: GroundTruth, a: int, b: int) -> float:
    """Smallest distance (m) between the world meshes of objects a and b (python-fcl; 0 when touching)."""
    import fcl

    def obj(oid):
        o = gt.object(oid)
        model = fcl.BVHModel()
        model.beginModel(len(o.vertices), len(o.faces))
        model.addSubModel(o.world_vertices(), np.asarray(o.faces, np.int32))
        model.endModel()
        return fcl.CollisionObject(model, fcl.Transform())

    result = fcl.DistanceResult()
    return max(0.0, float(fcl.distance(obj(a), obj(b), fcl.DistanceRequest(), result)))


def relation_problems(gt: GroundTruth, tolerance: float = 0.01) -> list[str]:
    """Relations that are not geometrically true within ``tolerance`` (m); empty when all hold."""
    problems = []
    walls = {w.id: w for w in gt.shell.walls}
    for rel in gt.relations:
        verts = gt.object(rel.child).world_vertices()
        if rel.relation == Relation.RESTS_ON and rel.parent == Root.FLOOR:
            gap = float(verts[:, 2].min())
            if abs(gap) > tolerance:
                problems.append(f"object {rel.child} rests on the floor but its bottom is at z = {gap:.4f} m")
        elif rel.relation == Relation.RESTS_ON:
            parent = int(rel.parent)
            d = mesh_distance(gt, rel.child, parent)
            pz = gt.object(parent).world_vertices()[:, 2]
            if d > tolerance:
                problems.append(f"object {rel.child} rests on object {parent} but is {d:.4f} m away")
            if verts[:, 2].min() < pz.min() + 1e-6:
                problems.append(f"object {rel.child} rests on object {parent} but reaches below its bottom")
        elif rel.relation == Relation.MOUNTS_ON:
            wall = walls.get(rel.wall_id)
            if wall is None:
                problems.append(f"object {rel.child} mounts on unknown wall {rel.wall_id}")
                continue
            dist = wall.plane.signed_distance(verts)
            if abs(float(dist.min())) > tolerance:
                problems.append(f"object {rel.child} mounts on wall {wall.id} at {dist.min():.4f} m from it")
            (x0, y0), (x1, y1) = wall.segment
            u = np.array([x1 - x0, y1 - y0])
            s = (verts[:, :2] - [x0, y0]) @ u / (u @ u)
            if s.min() < -1e-6 or s.max() > 1 + 1e-6:
                problems.append(f"object {rel.child} mounts on wall {wall.id} but reaches past its ends")
            if verts[:, 2].min() < -tolerance:
                problems.append(f"object {rel.child} on wall {wall.id} reaches below the floor")
    return problems


def interpenetrations(gt: GroundTruth, max_volume: float = 1e-6) -> list[tuple[int, int, float]]:
    """Pairs of objects whose meshes overlap by more than ``max_volume`` (m^3): (a, b, volume)."""
    solids, boxes = {}, {}
    for o in gt.objects:
        v = o.world_vertices()
        solids[o.object_id] = _solid(v, o.faces)
        boxes[o.object_id] = (v.min(0), v.max(0))
    out = []
    for a, b in itertools.combinations(sorted(solids), 2):
        (la, ha), (lb, hb) = boxes[a], boxes[b]
        if np.any(la > hb) or np.any(lb > ha):
            continue
        vol = float((solids[a] ^ solids[b]).volume())
        if vol > max_volume:
            out.append((a, b, vol))
    return out


def outside_room(gt: GroundTruth, tolerance: float = 0.005) -> list[int]:
    """Objects with a vertex outside the room (beyond the walls, below the floor, above the ceiling)."""
    poly = gt.shell.polygon().buffer(tolerance)
    top = (gt.shell.ceiling_height or np.inf) + tolerance
    bad = []
    for o in gt.objects:
        v = o.world_vertices()
        if v[:, 2].min() < -tolerance or v[:, 2].max() > top or not all(poly.contains(Point(p)) for p in v[:, :2]):
            bad.append(o.object_id)
    return bad
