"""Room-shell estimation: the gravity-aligned floor plane, vertical wall planes and the floor polygon.

World frame: metres, z up (the capture's ``up: +z``). The floor plane is snapped to ``z = h`` (normal +z),
and wall normals are made exactly horizontal and point into the room (towards the cameras, which stand
inside it).

With structural labels (instances labelled ``floor`` / ``wall`` with ``structural=True``) the planes are fitted
to those instances' points. Without them the floor is the lowest dense horizontal slab of all points and
walls are vertical RANSAC planes (Open3D ``segment_plane``) that are tall enough and have almost no points
behind them (furniture faces have the room behind them). The floor polygon is the intersection of the
walls' inner half-planes with the convex hull of the floor points when the room is convex (the floor
points lie inside that intersection), which also closes an open side along the floor's edge; otherwise the
floor's concave hull with the region behind each wall segment cut away.

That polygon is the floor that was seen. A capture that walks one side of a room (a head-mounted or phone
camera looking down) sees the floor in patches; the furniture and the cameras stand on floor beyond them.
Each edge of the seen polygon that lies on no observed wall is open, and across the open edges the floor's
extent grows to the convex hull of the seen floor, every object's footprint (its points seen from above)
and the cameras' positions, except behind an observed wall. ``floor_polygon`` is that extent,
``seen_floor_polygon`` the seen floor, and ``edge_walls`` names the wall under each edge of the extent (None:
open, nothing was seen to bound the room there).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import open3d as o3d
import shapely
from numpy.typing import NDArray
from shapely.geometry import LineString, MultiPoint, Polygon
from shapely.geometry.polygon import orient
from shapely.ops import polygonize, unary_union

from rescene_core.capture import Capture
from rescene_core.config import ShellConfig
from rescene_core.geometry.open3d_rng import seeded_open3d_rng
from rescene_core.records import Plane, RoomShell, WallPlane

log = logging.getLogger(__name__)


class ShellError(ValueError):
    """The capture has too little geometry for a room shell (the message says what is missing)."""


@dataclass
class _Wall:
    normal: NDArray[np.float64]  # [2] horizontal unit normal into the room
    offset: float
    s_range: tuple[float, float]  # extent along the tangent (-n_y, n_x), metres
    support: int
    points: NDArray[np.float64]  # [k, 3] the points the plane was fitted to (within wall_refine_band)

    @property
    def tangent(self) -> NDArray[np.float64]:
        return np.array([-self.normal[1], self.normal[0]])

    def endpoints(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        foot = -self.offset * self.normal
        return foot + self.s_range[0] * self.tangent, foot + self.s_range[1] * self.tangent


def _downsample(points: NDArray, voxel: float) -> NDArray[np.float64]:
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, np.float64)))
    if voxel > 0:
        pcd = pcd.voxel_down_sample(voxel)
    return np.asarray(pcd.points)


def _segment(points: NDArray[np.float64], config: ShellConfig) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    plane, inliers = pcd.segment_plane(config.ransac_distance, 3, config.ransac_iterations)
    return np.asarray(plane, np.float64), np.asarray(inliers, np.int64)


def _floor_height_labelled(points: NDArray[np.float64], config: ShellConfig) -> float:
    if len(points) >= 3:
        plane, inl = _segment(points, config)
        if abs(plane[2]) / np.linalg.norm(plane[:3]) >= np.cos(np.radians(config.vertical_tolerance_deg)):
            return float(np.median(points[inl, 2]))
        log.warning("floor points are not horizontal (normal %s); using their median height", plane[:3])
    return float(np.median(points[:, 2]))


def _floor_height_unlabelled(points: NDArray[np.float64], config: ShellConfig) -> float:
    """Lowest height bin holding >= floor_min_fraction of the densest bin, refined by a plane fit."""
    z = points[:, 2]
    step = config.ransac_distance
    edges = np.arange(z.min(), z.max() + 2 * step, step)
    counts, edges = np.histogram(z, bins=edges)
    dense = np.flatnonzero(counts >= config.floor_min_fraction * counts.max())
    z0 = 0.5 * (edges[dense[0]] + edges[dense[0] + 1])
    slab = points[np.abs(z - z0) <= 2 * step]
    return _floor_height_labelled(slab, config) if len(slab) >= 3 else float(z0)


def _orient(normal: NDArray, offset: float, inside: NDArray[np.float64]) -> tuple[NDArray, float]:
    """Flip a horizontal line's normal so the reference points ``inside`` [k, 2] lie on its positive side."""
    if len(inside) and np.median(inside @ normal + offset) < 0:
        return -normal, -offset
    return normal, offset


def _refine(
    points: NDArray[np.float64], normal: NDArray[np.float64], offset: float, config: ShellConfig, width: float
) -> tuple[NDArray[np.float64], float, NDArray[np.bool_]]:
    """Refit a vertical plane to the points [m, 3] within ``width`` (m) of it: horizontal normal from a
    total-least-squares line through their (x, y), offset the median of their projections (a depth-noise slab
    is centred, not cut at one side as a thin RANSAC band would). Returns normal [2], offset, band mask [m]."""
    xy = points[:, :2]
    band = np.abs(xy @ normal + offset) <= width
    for _ in range(config.wall_refine_iterations):
        if band.sum() < 3:
            break
        sel = xy[band]
        centred = sel - sel.mean(axis=0)
        _, _, vt = np.linalg.svd(centred, full_matrices=False)
        n = vt[1] if vt[1] @ normal >= 0 else -vt[1]
        if n @ normal >= np.cos(np.radians(config.merge_angle_deg)):
            normal = n / np.linalg.norm(n)
        offset = -float(np.median(sel @ normal))
        band = np.abs(xy @ normal + offset) <= width
    return normal, offset, band


def _make_wall(normal: NDArray, offset: float, pts: NDArray[np.float64]) -> _Wall:
    s = pts[:, :2] @ np.array([-normal[1], normal[0]])
    return _Wall(normal, offset, (float(np.percentile(s, 1)), float(np.percentile(s, 99))), len(pts), pts)


def _vertical_planes(
    points: NDArray[np.float64],
    config: ShellConfig,
    inside: NDArray[np.float64],
    outer_check: NDArray[np.float64] | None,
    width: float,
) -> list[_Wall]:
    """Vertical planes by repeated RANSAC, each refitted to the points within ``width`` (m; ``_refine``).
    outer_check: all points [m, 2]; when given, a plane is a wall only if it is tall enough and at most
    ``wall_max_outside_fraction`` of them lie behind it within its extent."""
    walls: list[_Wall] = []
    remaining = points
    cos_tol = np.sin(np.radians(config.vertical_tolerance_deg))
    for _ in range(config.max_walls * 4):
        if len(remaining) < max(config.min_wall_points, 3) or len(walls) >= config.max_walls:
            break
        plane, inl = _segment(remaining, config)
        if len(inl) < config.min_wall_points:
            break
        n = plane[:3] / np.linalg.norm(plane[:3])
        if abs(n[2]) <= cos_tol:
            nh = n[:2] / np.linalg.norm(n[:2])
            xy = remaining[:, :2]
            offset = -float(np.median(xy[inl] @ nh))
            nh, offset, near = _refine(remaining, nh, offset, config, width)
            nh, offset = _orient(nh, offset, inside)
            pts_in = remaining[near]
            ok = near.sum() >= config.min_wall_points
            if ok and outer_check is not None:
                height = np.percentile(pts_in[:, 2], 98) - np.percentile(pts_in[:, 2], 2)
                # behind the plane within its extent: a furniture face has the room behind it, a wall
                # (also the inner wall of an L-shaped room's notch) has nothing
                seg = _make_wall(nh, offset, pts_in)
                s_out = outer_check @ seg.tangent
                within = (s_out >= seg.s_range[0]) & (s_out <= seg.s_range[1])
                behind = np.mean((outer_check @ nh + offset < -width) & within)
                ok = height >= config.wall_min_height and behind <= config.wall_max_outside_fraction
            if ok:
                walls.append(_make_wall(nh, offset, pts_in))
            remaining = remaining[~near]
        else:
            mask = np.ones(len(remaining), bool)
            mask[inl] = False
            remaining = remaining[mask]
    return walls


def _overlap(a: _Wall, b: _Wall) -> float:
    """Length (m) by which b's segment overlaps a's along a's tangent (negative: the gap between them)."""
    s = sorted(float(p @ a.tangent) for p in b.endpoints())
    return min(a.s_range[1], s[1]) - max(a.s_range[0], s[0])


def _merge(walls: list[_Wall], config: ShellConfig, width: float) -> list[_Wall]:
    """Merge planes of one wall: near-parallel, and either collinear (offsets within ``2 ransac_distance``;
    pieces of a wall split by occluders) or within ``merge_distance`` with overlapping segments (a noisy
    slab fitted twice). The merged plane is refitted to the union of both point sets, starting from the
    better-supported plane; the largest merges first."""
    merged: list[_Wall] = []
    cos_merge = np.cos(np.radians(config.merge_angle_deg))
    for w in sorted(walls, key=lambda w: -w.support):
        for k, m in enumerate(merged):
            if float(w.normal @ m.normal) < cos_merge:
                continue
            gap = abs(w.offset - m.offset)
            if gap <= 2 * config.ransac_distance or (gap <= config.merge_distance and _overlap(m, w) > 0):
                pts = np.concatenate([m.points, w.points])
                n, off, band = _refine(pts, m.normal, m.offset, config, width)
                merged[k] = _make_wall(n, off, pts[band] if band.sum() >= 3 else pts)
                break
        else:
            merged.append(w)
    return merged


def _outermost(walls: list[_Wall], config: ShellConfig) -> list[_Wall]:
    """Drop a wall plane that stands in front of another wall of the same direction over most of its length
    (their segments overlap along the wall by more than ``wall_shadow_overlap`` of the shorter one): the room
    ends at the wall behind. Wall-labelled points on a furniture face (wall cabinets, a mask that drifted
    onto them) otherwise give a second, inner wall that pushes everything standing under it into the room.
    A notch of an L-shaped room or an alcove has parallel walls side by side, not one behind the other."""
    cos_merge = np.cos(np.radians(config.merge_angle_deg))
    dropped: set[int] = set()
    for i, a in enumerate(walls):
        for j, b in enumerate(walls):
            if i == j or j in dropped or float(a.normal @ b.normal) < cos_merge:
                continue
            # b lies behind a (a's normal points into the room): a's plane has b's points on its outer side
            foot_b = -b.offset * b.normal
            if float(a.normal @ foot_b) + a.offset >= -config.merge_distance:
                continue
            shorter = min(a.s_range[1] - a.s_range[0], b.s_range[1] - b.s_range[0])
            if shorter > 0 and _overlap(a, b) > config.wall_shadow_overlap * shorter:
                dropped.add(i)
                break
    kept = [w for k, w in enumerate(walls) if k not in dropped]
    if dropped:
        log.info("room shell: %d wall plane(s) in front of another wall dropped", len(dropped))
    return kept


def _largest(geom) -> Polygon | None:
    if geom.is_empty:
        return None
    if isinstance(geom, Polygon):
        return geom
    polys = [g for g in getattr(geom, "geoms", []) if isinstance(g, Polygon)]
    return max(polys, key=lambda p: p.area) if polys else None


def _behind(w: _Wall, xy: NDArray[np.float64], margin: float) -> NDArray[np.bool_]:
    """Points [k, 2] behind wall w (further than ``margin``) and within its segment's extent along it."""
    s = xy @ w.tangent
    return (xy @ w.normal + w.offset < -margin) & (s >= w.s_range[0] - margin) & (s <= w.s_range[1] + margin)


def _line(w: _Wall, reach: float) -> LineString:
    foot = -w.offset * w.normal
    return LineString([foot - reach * w.tangent, foot + reach * w.tangent])


def _strip(w: _Wall, config: ShellConfig) -> Polygon:
    """The band in front of a wall segment, ``polygon_snap_distance`` deep, ``polygon_sliver`` longer at each end."""
    a, b = w.endpoints()
    t, n = w.tangent, w.normal
    a, b = a - config.polygon_sliver * t, b + config.polygon_sliver * t
    d = config.polygon_snap_distance
    return Polygon([a, b, b + d * n, a + d * n])


def _polygon(floor_xy: NDArray[np.float64], all_xy: NDArray[np.float64], walls: list[_Wall], config: ShellConfig):
    """Floor polygon [v, 2] (counter-clockwise) from the floor outline and the wall segments.

    The outline R0 is the hull of the floor points (``polygon_concave_ratio``). The wall lines cut R0 grown
    by ``polygon_snap_distance`` into cells; a cell is floor when R0 covers at least
    ``polygon_cell_min_coverage`` of it and it does not lie behind a wall segment. Within the kept cells the
    polygon is R0 plus a strip in front of each wall segment, so wherever a wall bounds the room the edge
    lies on the wall's line, and an open side keeps the outline of the floor points. An opening by
    ``polygon_sliver`` removes spikes and slivers."""
    base_xy = floor_xy if len(floor_xy) >= 3 else all_xy
    outline = _largest(shapely.concave_hull(MultiPoint(base_xy), ratio=config.polygon_concave_ratio))
    outline = outline or _largest(MultiPoint(base_xy).convex_hull)
    if outline is None or outline.area <= 0:
        raise ShellError("cannot form a floor polygon: the floor points span no area")
    poly = outline
    if walls:
        domain = outline.buffer(config.polygon_snap_distance, join_style="mitre")
        reach = float(np.linalg.norm(np.subtract(*np.reshape(domain.bounds, (2, 2))))) + 1.0
        pieces = polygonize(unary_union([domain.exterior] + [_line(w, reach) for w in walls]))
        cells = [c for c in pieces if c.area > 0 and domain.contains(c.representative_point())]
        keep = []
        for c in cells:
            rp = np.array(c.representative_point().coords)[:1]
            covered = c.intersection(outline).area / c.area
            shadowed = any(_behind(w, rp, 0.0)[0] for w in walls)
            if covered >= config.polygon_cell_min_coverage and not shadowed:
                keep.append(c)
        if keep:
            reach_out = unary_union([outline.buffer(config.ransac_distance)] + [_strip(w, config) for w in walls])
            poly = _largest(unary_union(keep).intersection(reach_out)) or outline
        else:
            log.warning("no arrangement cell of the wall lines is covered by floor; the polygon is the floor outline")
    eps = config.polygon_sliver
    opened = _largest(poly.buffer(-eps, join_style="mitre").buffer(eps, join_style="mitre"))
    poly = opened if opened is not None and opened.area >= 0.5 * poly.area else poly
    poly = _largest(poly.simplify(config.polygon_simplify)) or poly
    poly = orient(poly, 1.0)
    return tuple((float(x), float(y)) for x, y in list(poly.exterior.coords)[:-1])


def _split_at_wall_ends(ring: list[NDArray[np.float64]], walls: list[_Wall], config: ShellConfig) -> list:
    """The polygon's vertices [v][2] with a vertex added where an observed wall segment ends on an edge (more
    than ``polygon_snap_distance`` from its corners), so an edge is walled or open along its whole length."""
    tol = 2 * config.ransac_distance
    out: list[NDArray[np.float64]] = []
    for k, a in enumerate(ring):
        b = ring[(k + 1) % len(ring)]
        out.append(a)
        d = b - a
        length = float(np.linalg.norm(d))
        if length <= 2 * config.polygon_snap_distance:
            continue
        cuts = []
        for w in walls:
            for e in w.endpoints():
                t = float((e - a) @ d) / length**2
                off = abs(float(d[0] * (e - a)[1] - d[1] * (e - a)[0])) / length
                if off <= tol and config.polygon_snap_distance < t * length < length - config.polygon_snap_distance:
                    cuts.append(t)
        out += [a + t * d for t in sorted(cuts)]
    return out


def _edge_walls(ring: list[NDArray[np.float64]], walls: list[_Wall], config: ShellConfig) -> list[int | None]:
    """Per edge k (vertex k to k + 1) the index of the wall it lies on: both ends within ``2 ransac_distance``
    of the wall's line and its middle within the wall's segment grown by ``polygon_snap_distance`` (segments
    end at their points' 1st and 99th percentiles, a little short of the corners); None: no wall, an open side."""
    tol = 2 * config.ransac_distance
    tags: list[int | None] = []
    for k, a in enumerate(ring):
        b = ring[(k + 1) % len(ring)]
        mid = 0.5 * (a + b)
        best: tuple[float, int] | None = None
        for j, w in enumerate(walls):
            off = max(abs(float(p @ w.normal) + w.offset) for p in (a, b))
            s = float(mid @ w.tangent)
            inside = w.s_range[0] - config.polygon_snap_distance <= s <= w.s_range[1] + config.polygon_snap_distance
            if off <= tol and inside and (best is None or off < best[0]):
                best = (off, j)
        tags.append(None if best is None else best[1])
    return tags


def _beyond(a: NDArray, b: NDArray, reach: float) -> Polygon:
    """The band ``reach`` m deep outwards from the edge a -> b of a counter-clockwise polygon."""
    d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-12)
    out = np.array([d[1], -d[0]])
    return Polygon([a, b, b + reach * out, a + reach * out])


FOOTPRINT_STRAY = 0.1
"""An object's point lying beyond the 1st-99th percentile range of its points (per horizontal axis) by more
than this share of that range is a stray (segmentation bleed), left out of its footprint."""


def _footprints(capture: Capture, points: NDArray[np.float64], point_ids: NDArray) -> list[Polygon]:
    """Each object's footprint: the convex hull of its points' (x, y), strays left out (``FOOTPRINT_STRAY``).
    Every object, on the floor, on another object or on a wall, stands over the room's floor."""
    out = []
    for inst in capture.instances:
        if inst.structural:
            continue
        xy = points[point_ids == int(inst.id), :2]
        if len(xy) < 3:
            continue
        lo, hi = np.percentile(xy, 1, axis=0), np.percentile(xy, 99, axis=0)
        lo, hi = lo - FOOTPRINT_STRAY * (hi - lo), hi + FOOTPRINT_STRAY * (hi - lo)
        xy = xy[((xy >= lo) & (xy <= hi)).all(axis=1)]
        hull = MultiPoint(xy).convex_hull if len(xy) >= 3 else None
        if isinstance(hull, Polygon) and hull.area > 0:
            out.append(hull)
    return out


def _extent(
    seen: tuple[tuple[float, float], ...],
    walls: list[_Wall],
    footprints: list[Polygon],
    cams_xy: NDArray[np.float64],
    config: ShellConfig,
) -> tuple[tuple[tuple[float, float], ...], list[int | None]]:
    """The floor's extent (counter-clockwise vertices) and its edges' walls (``_edge_walls``): the seen floor,
    grown across its open edges to the convex hull of the seen floor, the object ``footprints`` and the
    cameras' positions ``cams_xy`` [k, 2], except where it lies behind an observed wall segment. A room whose
    every side is walled keeps the seen floor as it is."""
    ring = _split_at_wall_ends([np.asarray(p, np.float64) for p in seen], walls, config)
    tags = _edge_walls(ring, walls, config)
    if all(t is not None for t in tags):
        return tuple((float(x), float(y)) for x, y in ring), tags
    seen_poly = Polygon(ring)
    hull = unary_union([seen_poly, *footprints, MultiPoint(cams_xy) if len(cams_xy) else Polygon()]).convex_hull
    reach = float(np.linalg.norm(np.subtract(*np.reshape(hull.bounds, (2, 2))))) + 1.0
    across = [_beyond(ring[k], ring[(k + 1) % len(ring)], reach) for k, t in enumerate(tags) if t is None]
    for k, t in enumerate(tags):  # the wedge outside a convex corner between two open edges
        v, prev, nxt = ring[k], ring[k - 1], ring[(k + 1) % len(ring)]
        turn = (v - prev)[0] * (nxt - v)[1] - (v - prev)[1] * (nxt - v)[0]
        if t is None and tags[k - 1] is None and turn > 0:
            d_in = (v - prev) / max(float(np.linalg.norm(v - prev)), 1e-12)
            d_out = (v - nxt) / max(float(np.linalg.norm(v - nxt)), 1e-12)
            across.append(Polygon([v, v + reach * d_in, v + reach * d_out]))
    behind = []
    for w in walls:  # a wall's back, over its segment grown by the snap distance
        a, b = w.endpoints()
        a, b = a - config.polygon_snap_distance * w.tangent, b + config.polygon_snap_distance * w.tangent
        behind.append(Polygon([a, b, b - reach * w.normal, a - reach * w.normal]))
    grown = hull.intersection(unary_union(across)).difference(unary_union(behind))
    extent = _largest(unary_union([seen_poly, grown]).buffer(0)) or seen_poly
    eps = config.polygon_sliver
    opened = _largest(extent.buffer(-eps, join_style="mitre").buffer(eps, join_style="mitre"))
    if opened is not None and seen_poly.difference(opened).area <= eps * seen_poly.length:
        extent = opened  # (the opening of the seen floor alone was done; it may shave a mitre's tip)
    extent = _largest(extent.simplify(config.polygon_simplify)) or seen_poly
    # no zero-width spike where the growth meets the seen floor's outline, no collinear vertex
    extent = _largest(extent.buffer(-1e-6, join_style="mitre").buffer(1e-6, join_style="mitre")) or extent
    extent = orient(shapely.simplify(extent, 1e-6), 1.0)
    ring = _split_at_wall_ends([np.asarray(p, np.float64) for p in list(extent.exterior.coords)[:-1]], walls, config)
    return tuple((float(x), float(y)) for x, y in ring), _edge_walls(ring, walls, config)


def estimate_shell(capture: Capture, config: ShellConfig | None = None) -> RoomShell:
    """The room shell of a capture (see the module docstring). Raises ShellError when there are no points."""
    config = config or ShellConfig()
    # RANSAC plane fits draw from Open3D's process-wide engine: seed it and keep it to this thread
    with seeded_open3d_rng(config.seed):
        return _estimate_shell(capture, config)


def _estimate_shell(capture: Capture, config: ShellConfig) -> RoomShell:
    points, point_ids = capture.all_points()
    finite = np.isfinite(points).all(axis=1)
    points, point_ids = points[finite].astype(np.float64), point_ids[finite]
    if len(points) < 3:
        raise ShellError(f"{capture.path}: the capture has {len(points)} finite instance points; a shell needs a floor")
    by_label: dict[str, list[int]] = {}
    for inst in capture.instances:
        if inst.structural:
            by_label.setdefault(inst.label, []).append(int(inst.id))
    cams = capture.world_from_cam[:, :3, 3]
    cams = cams[np.isfinite(cams).all(axis=1)]
    thin = _downsample(points, config.sample_voxel)

    floor_pts = points[np.isin(point_ids, by_label.get("floor", []))]
    if len(floor_pts) >= 3:
        floor_z = _floor_height_labelled(_downsample(floor_pts, config.sample_voxel), config)
        floor_xy = floor_pts[:, :2]
        source = "labels"
    else:
        floor_z = _floor_height_unlabelled(thin, config)
        floor_xy = thin[np.abs(thin[:, 2] - floor_z) <= config.ransac_distance, :2]
        source = "points"
    inside = cams[:, :2] if len(cams) else floor_xy.mean(axis=0, keepdims=True)

    wall_ids = by_label.get("wall", [])
    walls: list[_Wall] = []
    width = config.wall_refine_band
    if wall_ids:
        for wid in wall_ids:
            wp = points[point_ids == wid]
            if len(wp) >= 3:
                walls += _vertical_planes(_downsample(wp, config.sample_voxel), config, inside, None, width)
    else:
        # without labels a wide slab would take in furniture standing near the wall: fit to the RANSAC band
        width = config.ransac_distance
        above = thin[thin[:, 2] > floor_z + 3 * config.ransac_distance]
        walls = _vertical_planes(above, config, inside, thin[:, :2], width)
    walls = _outermost(_merge(walls, config, width), config)[: config.max_walls]
    # Wall points mark the room's outline where furniture hides the floor; the walls then cut what lies behind.
    outline_xy = floor_xy
    if wall_ids:
        outline_xy = np.concatenate(
            [floor_xy, _downsample(points[np.isin(point_ids, wall_ids)], config.sample_voxel)[:, :2]]
        )
    seen = _polygon(outline_xy, points[:, :2], walls, config)
    polygon, edge_walls = _extent(seen, walls, _footprints(capture, points, point_ids), cams[:, :2], config)

    ceiling_pts = points[np.isin(point_ids, by_label.get("ceiling", []))]
    ceiling = float(np.median(ceiling_pts[:, 2]) - floor_z) if len(ceiling_pts) else None
    log.info(
        "room shell from %s: floor z=%.3f, %d walls, %d polygon vertices, %d open edges, floor seen %.1f of %.1f m^2",
        source,
        floor_z,
        len(walls),
        len(polygon),
        sum(t is None for t in edge_walls),
        Polygon(seen).area,
        Polygon(polygon).area,
    )
    return RoomShell(
        floor=Plane((0.0, 0.0, 1.0), -floor_z),
        walls=tuple(
            WallPlane(
                k,
                Plane((float(w.normal[0]), float(w.normal[1]), 0.0), float(w.offset)),
                tuple(tuple(float(v) for v in p) for p in w.endpoints()),
            )
            for k, w in enumerate(walls)
        ),
        floor_polygon=polygon,
        ceiling_height=ceiling,
        edge_walls=tuple(edge_walls),
        seen_floor_polygon=seen,
    )
