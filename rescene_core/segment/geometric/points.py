"""The scan's points off the structure, their superpoints (``ScanPoints``) and the bookkeeping of
regions over them: points per region, connected parts, bounds, touching regions, regrouping."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.superpoints import SuperpointGraph, edge_weights, felzenszwalb, point_graph, superpoint_graph


@dataclass
class ScanPoints:
    """The fused surface off the floor and ceiling, thinned, with its superpoints.

    points, normals (unit), colours (RGB in [0, 1]): [n, 3], world frame. wall: [n] id of the wall plane the
    point lies on (0: none). vertex_point: [v] the point each mesh vertex maps to (-1: none, e.g. floor).
    edges: [e, 2] the point graph; concave, colour_step: [e] each edge's concave crease and colour step
    (``edge_weights``), fixed with the points whatever superpoints they fall in. graph: the superpoints and
    their contacts."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    colours: NDArray[np.float64]
    wall: NDArray[np.int64]
    vertex_point: NDArray[np.int64]
    edges: NDArray[np.int64]
    concave: NDArray[np.bool_]
    colour_step: NDArray[np.float64]
    graph: SuperpointGraph


def scan_points(
    verts: NDArray, normals: NDArray, colours: NDArray, struct: NDArray[np.int64], planes: list[dict[str, Any]],
    cfg: SegmentConfig, fh_k: float | None = None,
) -> ScanPoints:  # fmt: skip
    """Thin the free and wall vertices (each wall on its own, so a point is either on a wall or not) to
    ``superpoint_voxel`` and over-segment them into superpoints (``rescene_core.segment.superpoints``) at
    the scale ``fh_k`` (default ``cfg.fh_k``)."""
    import open3d as o3d

    groups = [0] + [int(p["id"]) for p in planes if p["kind"] == "wall"]
    pts, nrm, col, wall = [], [], [], []
    vertex_point = np.full(len(verts), -1, np.int64)
    offset = 0
    for gid in groups:
        sel = np.flatnonzero(struct == gid)
        if len(sel) == 0:
            continue
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[sel]))
        pcd.normals = o3d.utility.Vector3dVector(normals[sel])
        pcd.colors = o3d.utility.Vector3dVector(np.clip(colours[sel], 0.0, 1.0))
        pcd = pcd.voxel_down_sample(cfg.superpoint_voxel)
        p = np.asarray(pcd.points)
        near = cKDTree(p).query(verts[sel], k=1)[1]
        vertex_point[sel] = offset + near
        pts.append(p)
        nrm.append(np.asarray(pcd.normals))
        col.append(np.asarray(pcd.colors))
        wall.append(np.full(len(p), gid, np.int64))
        offset += len(p)
    if not pts:
        raise SegmentError("nothing is left off the floor and ceiling to segment (the scan shows no objects or walls)")
    P, N, C, Wl = np.concatenate(pts), np.concatenate(nrm), np.concatenate(col), np.concatenate(wall)
    N = N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-9)
    edges = point_graph(P, cfg.superpoint_voxel * cfg.graph_radius_voxels)
    weights, concave, step = edge_weights(P, N, C, edges, cfg.fh_colour_weight)
    label = felzenszwalb(len(P), edges, weights, cfg.fh_k if fh_k is None else fh_k, cfg.fh_min_size)
    graph = superpoint_graph(P, N, C, label, edges, concave, step)
    return ScanPoints(P, N, C, Wl, vertex_point, edges, concave, step, graph)


def points_by_region(point_region: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The point indices sorted by region (``point_region`` [k], ids below ``n``) and where each region's run
    starts [n + 1]: region r's points are ``order[start[r] : start[r + 1]]``."""
    order = np.argsort(point_region, kind="stable")
    return order, np.searchsorted(point_region[order], np.arange(n + 1))


def _point_parts(
    edges: NDArray[np.int64], mask: NDArray[np.bool_], keep: NDArray[np.bool_] | None = None
) -> tuple[int, NDArray[np.int64]]:
    """Connected parts of the points ``mask`` [n] over the point graph's ``edges`` [e, 2] joining two of them
    (and ``keep`` [e] when given): how many, and the part of each point [n] (0..k-1; -1 outside the mask)."""
    i0, i1 = edges[:, 0], edges[:, 1]
    join = mask[i0] & mask[i1] if keep is None else mask[i0] & mask[i1] & keep
    local = np.cumsum(mask) - 1  # index among the masked points
    m = int(mask.sum())
    adj = coo_matrix((np.ones(int(join.sum())), (local[i0[join]], local[i1[join]])), shape=(m, m))
    k, sub = connected_components(adj, directed=False)
    part = np.full(len(mask), -1, np.int64)
    part[mask] = sub
    return int(k), part


def _components(n: int, pairs: NDArray[np.int64], keep: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Connected component [n] of the graph with the ``keep`` pairs as edges."""
    e = pairs[keep]
    adj = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return np.asarray(connected_components(adj, directed=False)[1], np.int64)


def _regrouped(
    sp: ScanPoints, region: NDArray[np.int64], which: NDArray[np.int64], point_region: NDArray[np.int64], changed: int
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """What a step that moved points between regions returns: the scan points regrouped by the new
    ``point_region`` [n] (``regroup``) with the region and wall of each new superpoint, and ``changed``
    (how many it split, parted or took off); all as they were when it changed nothing."""
    if changed == 0:
        return sp, region, which, 0
    sp, region, parent = regroup(sp, point_region)
    return sp, region, which[parent], changed


def regroup(sp: ScanPoints, point_region: NDArray[np.int64]) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64]]:
    """The scan points regrouped after regions were split across superpoints: each superpoint cut in as
    many as the regions of its points (``point_region`` [n]). Returns the scan points with the new
    superpoint graph, the region [s'] of each new superpoint and the superpoint [s'] it was cut from (to
    carry what each superpoint holds, such as its wall)."""
    nxt = int(point_region.max(initial=0)) + 1
    key = sp.graph.label * nxt + point_region
    uk, label = np.unique(key, return_inverse=True)
    graph = superpoint_graph(
        sp.points, sp.normals, sp.colours, label.astype(np.int64), sp.edges, sp.concave, sp.colour_step
    )
    return replace(sp, graph=graph), (uk % nxt).astype(np.int64), (uk // nxt).astype(np.int64)


def _region_bounds(g: SuperpointGraph, region: NDArray[np.int64], n: int) -> tuple[NDArray, NDArray]:
    """Axis-aligned bounds ``lo``, ``hi`` [n, 3] (m) of each of ``n`` regions, from the bounds of the
    superpoints ``region`` [s] assigns to them (a region without superpoints: +inf, -inf)."""
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, region, g.lo)
    np.maximum.at(hi, region, g.hi)
    return lo, hi


def _touching_regions(
    g: SuperpointGraph, region: NDArray[np.int64], n: int, min_contacts: int, among: NDArray[np.bool_] | None = None
) -> list[tuple[int, int]]:
    """Pairs (a, b), a < b, of regions (``region`` [s] of each superpoint of graph ``g``, ids below ``n``, 0:
    none) whose superpoints touch with at least ``min_contacts`` graph contacts; with ``among`` [n], only
    pairs of which at least one region is marked."""
    ra, rb = region[g.pairs[:, 0]], region[g.pairs[:, 1]]
    ok = (ra > 0) & (rb > 0) & (ra != rb)
    if among is not None:
        ok &= among[ra] | among[rb]
    key = np.minimum(ra[ok], rb[ok]) * n + np.maximum(ra[ok], rb[ok])
    uk, inv = np.unique(key, return_inverse=True)
    contacts = np.bincount(inv, g.contacts[ok], len(uk))
    return [(k // n, k % n) for k in uk[contacts >= min_contacts].tolist()]


def _facing_up(normals: NDArray) -> NDArray[np.bool_]:
    """Whether each unit normal [k, 3] (z up) is within 15 degrees of up: the points of a horizontal top."""
    return normals[:, 2] > np.cos(np.radians(15.0))
