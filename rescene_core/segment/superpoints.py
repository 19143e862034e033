"""Superpoints of a fused scan: Felzenszwalb-Huttenlocher graph segmentation on a point graph by normals
and colour, as ScanNet's over-segmentation does on its meshes (Felzenszwalb and Huttenlocher, "Efficient
graph-based image segmentation", IJCV 2004; ScanNet's ``Segmentator``).

The points are the fused surface thinned to a voxel grid (Open3D's ``voxel_down_sample``, which averages
positions, normals and colours). Two points closer than a radius share an edge (scipy's ``cKDTree``). An
edge's weight is ``1 - n_i . n_j``, squared when the edge is convex (the normals open away from each
other: ``(n_i - n_j) . (p_i - p_j) > 0``, so the faces of one box stay together and the inner corner where
a lamp stands on a table does not), plus ``colour_weight`` times the RGB distance. Edges are joined in
order of weight while the weight stays below both components' internal difference plus ``k / size``;
components smaller than ``min_size`` then join their cheapest neighbour.

``SuperpointGraph`` holds, per superpoint, the point count, centroid, bounds, mean normal and colour, and
per pair of touching superpoints the contact edges, how many are concave and the colour step across them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree


def point_graph(points: NDArray[np.float64], radius: float) -> NDArray[np.int64]:
    """Edges [e, 2] (i < j) between points [n, 3] closer than ``radius`` (m)."""
    if len(points) < 2:
        return np.zeros((0, 2), np.int64)
    return np.asarray(cKDTree(points).query_pairs(radius, output_type="ndarray"), np.int64).reshape(-1, 2)


def edge_weights(
    points: NDArray[np.float64],
    normals: NDArray[np.float64],
    colors: NDArray[np.float64],
    edges: NDArray[np.int64],
    colour_weight: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """Weight [e], concavity [e] and colour step [e] of each edge.

    points, normals (unit), colors (RGB in [0, 1]): [n, 3]. The colour step is the RGB distance divided
    by sqrt(3), so it lies in [0, 1]."""
    i, j = edges[:, 0], edges[:, 1]
    dot = np.einsum("ij,ij->i", normals[i], normals[j])
    bend = np.clip(1.0 - dot, 0.0, 2.0)
    convexity = np.einsum("ij,ij->i", normals[i] - normals[j], points[i] - points[j])
    concave = convexity < 0.0
    bend = np.where(concave, bend, bend * bend)
    step = np.linalg.norm(colors[i] - colors[j], axis=1) / np.sqrt(3.0)
    return bend + colour_weight * step, concave & (dot < 0.95), step


def felzenszwalb(
    n: int, edges: NDArray[np.int64], weights: NDArray[np.float64], k: float, min_size: int
) -> NDArray[np.int64]:
    """Component label [n] (0..m-1, by first point) of Felzenszwalb-Huttenlocher segmentation of a graph
    with ``n`` nodes, ``edges`` [e, 2] and ``weights`` [e]; ``k`` sets the scale (larger: larger
    components), components below ``min_size`` nodes join their cheapest neighbour."""
    parent = list(range(n))
    size = [1] * n
    internal = [0.0] * n

    def find(x: int) -> int:
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    order = np.argsort(weights, kind="stable")
    e0 = edges[order, 0].tolist()
    e1 = edges[order, 1].tolist()
    ws = weights[order].tolist()
    for a, b, w in zip(e0, e1, ws):
        ra, rb = find(a), find(b)
        if ra == rb:
            continue
        if w <= internal[ra] + k / size[ra] and w <= internal[rb] + k / size[rb]:
            if size[ra] < size[rb]:
                ra, rb = rb, ra
            parent[rb] = ra
            size[ra] += size[rb]
            internal[ra] = w
    for a, b in zip(e0, e1):
        ra, rb = find(a), find(b)
        if ra != rb and (size[ra] < min_size or size[rb] < min_size):
            if size[ra] < size[rb]:
                ra, rb = rb, ra
            parent[rb] = ra
            size[ra] += size[rb]
    roots = np.fromiter((find(x) for x in range(n)), np.int64, n)
    _, labels = np.unique(roots, return_inverse=True)
    return labels.astype(np.int64)


@dataclass
class SuperpointGraph:
    """Superpoints of a thinned cloud and their contacts.

    label: [n] superpoint of each point. count [s], centroid [s, 3], lo / hi [s, 3] (bounds, m), normal
    [s, 3] (mean, unit or zero), up [s] (share of points with a normal within ``up_deg`` of +z), colour
    [s, 3] (mean RGB in [0, 1]). pairs [p, 2] (a < b): touching superpoints; contacts [p] edges between
    them, concave [p] how many of those are concave, step [p] mean colour step across them."""

    label: NDArray[np.int64]
    count: NDArray[np.int64]
    centroid: NDArray[np.float64]
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    normal: NDArray[np.float64]
    up: NDArray[np.float64]
    colour: NDArray[np.float64]
    pairs: NDArray[np.int64]
    contacts: NDArray[np.int64]
    concave: NDArray[np.int64]
    step: NDArray[np.float64]

    @property
    def size(self) -> int:
        return len(self.count)


def superpoint_graph(
    points: NDArray[np.float64],
    normals: NDArray[np.float64],
    colors: NDArray[np.float64],
    label: NDArray[np.int64],
    edges: NDArray[np.int64],
    concave: NDArray[np.bool_],
    step: NDArray[np.float64],
    up_deg: float = 15.0,
) -> SuperpointGraph:
    """Per-superpoint statistics and the contacts between superpoints (see ``SuperpointGraph``)."""
    s = int(label.max()) + 1 if len(label) else 0
    count = np.bincount(label, minlength=s)
    denom = np.maximum(count, 1)[:, None]
    centroid = np.stack([np.bincount(label, points[:, d], s) for d in range(3)], 1) / denom
    colour = np.stack([np.bincount(label, colors[:, d], s) for d in range(3)], 1) / denom
    normal = np.stack([np.bincount(label, normals[:, d], s) for d in range(3)], 1) / denom
    up = np.bincount(label, (normals[:, 2] > np.cos(np.radians(up_deg))).astype(float), s) / denom[:, 0]
    lo = np.full((s, 3), np.inf)
    hi = np.full((s, 3), -np.inf)
    np.minimum.at(lo, label, points)
    np.maximum.at(hi, label, points)
    la, lb = label[edges[:, 0]], label[edges[:, 1]]
    cross = la != lb
    a, b = np.minimum(la[cross], lb[cross]), np.maximum(la[cross], lb[cross])
    key = a * s + b
    uniq, inv = np.unique(key, return_inverse=True)
    contacts = np.bincount(inv, minlength=len(uniq))
    conc = np.bincount(inv, concave[cross].astype(np.int64), len(uniq)).astype(np.int64)
    stp = np.bincount(inv, step[cross], len(uniq)) / np.maximum(contacts, 1)
    pairs = np.stack([uniq // max(s, 1), uniq % max(s, 1)], 1).astype(np.int64)
    return SuperpointGraph(label, count, centroid, lo, hi, normal, up, colour, pairs, contacts, conc, stp)
