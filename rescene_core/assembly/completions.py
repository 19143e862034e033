"""Floor contact for generated meshes that lack their lower part: the snap the points allow, then a base.

A single-view completion often lacks what its view did not show of an object's lower part (a table top
without legs, a lamp shade without its stem, a nightstand seen over a bed). Registered on the object's
points, such a mesh hangs above the floor, and dropping it onto the floor moves it away from where the
capture saw it (``evidence.evidence_refuses``). Instead:

1. ``bounded_floor_snap``: the full snap when its mesh box explains the object's observed points
   (POINTS_FIT_MARGIN) as well as any height between the registered one and the floor does (within
   FIT_TIE); otherwise the height that explains the most, ties to the smallest move. The levelling, yaw
   and footprint corrections of the floor rule are kept. A mesh that is too short and too high comes down
   until its top meets the top of its points.
2. ``add_bases``: at the final pose, the gap left between the mesh and the floor is filled with a base, a
   convex solid from the floor to 1 cm into the mesh, under the part of the object the points show below
   the mesh (the xy hull of those points, clipped to the mesh's footprint), or under the mesh's own lowest
   part when the points show nothing there. It is a ``Completion`` (kind ``base``) in the object's asset
   frame: contact metrics count it and the exporters add it as a collider, so the simulator sees the same
   object the metrics judged.
3. Amodal bases (``seen_only_from_above``): an object whose observed points all lie in a band under its top
   (``amodal_top_band_m``), that band at least ``amodal_min_height_m`` above the floor, was seen only from
   above: a head-mounted camera looking down at a kitchen island sees its worktop and nothing of its body.
   Neither its points nor its generated mesh (a slab of the top, as the ``lift`` backend makes it) show
   where its body stands, so its base spans the mesh's whole footprint from the floor up to the lowest
   observed point: a block, not a slab on a stem under the mesh's lowest vertices. Each backend generates
   only what its view showed; attachment completes the rest the same way whatever the backend (a generator
   that did invent the body down to the floor leaves no gap, and gets no base).

4. Support bases (``propagate.support_with_base``): an object resting on another whose support correction
   the evidence refused (lowering its mesh would leave its observed points outside it) while those points
   reach down to the support's level: a lamp whose generated mesh is its shade without the stem, registered
   on the shade's points above a nightstand. The base fills from the support's top up into the mesh, under
   the points seen below the mesh, as item 2 does down to the floor.

A base is the generator's missing part, not something the capture saw whole, so it never takes space from a
neighbour: its outline is cut back (``clear_of_neighbours``) wherever another object (not one it carries or
rests on) has its mesh or a base below the base's top, a nightstand beside a bed whose points spread under
its mattress or a chair tucked between a table's legs.
"""

from __future__ import annotations

import numpy as np
import shapely
import trimesh
from numpy.typing import NDArray
from shapely.geometry import MultiPoint, Polygon

from rescene_core.assembly.evidence import points_fit, points_in_box
from rescene_core.assembly.objects import AssemblyObject, footprint
from rescene_core.assembly.room import Room
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import translation
from rescene_core.assembly.trim import MIN_POINTS, TOP_BIN, seen_top
from rescene_core.geometry.completion import cut_mesh
from rescene_core.geometry.sim3 import apply, inverse
from rescene_core.records import Completion, CompletionKind, InstanceId, Relation, Root

SNAP_STEPS = 41
"""Vertical positions tried between the registered height and the full floor snap."""
FIT_TIE = 0.01
"""Points-fit shares within this of the best count as equally good (the smallest move wins)."""
BASE_MIN_GAP = 0.005
"""A gap (m) between the mesh and the floor smaller than this needs no base."""
BASE_OVERLAP = 0.01
"""How far (m) a base reaches up into the mesh, so the two touch."""
BASE_LOW_BAND = 0.03
"""Points (and, without them, mesh vertices) this close (m) above the mesh bottom, or lower, outline the
base."""
BASE_MIN_POINTS = 12
"""Fewest observed points below the mesh bottom that outline a base by themselves."""
BASE_MIN_AREA = 0.0016
"""Smallest base outline (m^2, 4 x 4 cm); a smaller one is grown to it."""
BASE_CLEARANCE = 0.005
"""Gap (m) a base keeps from a neighbour's mesh or base."""
NEIGHBOUR_SAMPLES = 2000
"""Surface samples of a neighbour's mesh (besides its vertices) that say where it stands."""
CLEAR_DIRECTIONS = 24
"""Horizontal directions tried (besides the outline's own edge normals) for the cut keeping a base clear."""


TOP_UPPER_PERCENTILE = 95.0
"""The upper edge of the top the points show: this percentile of the heights at their top (``seen_top_band``)."""
TOP_SPREAD_PERCENTILE = 10.0
"""The lower edge of that top's spread: this percentile of the same heights."""


def seen_top_band(obj: AssemblyObject, room: Room) -> tuple[float, float] | None:
    """How high generated ``obj``'s observed points show the object reaching, as the upper and lower edges
    (TOP_UPPER_PERCENTILE, TOP_SPREAD_PERCENTILE; m above the floor) of the heights of its points in the
    registered mesh box within two bins below the upper edge of their highest dense height bin (``trim.seen_top``: a child's sparse bleed above the top does
    not count): a worktop seen from above, or the upper edge of a side seen up to there. None for an exact
    shape, or when fewer than ``trim.MIN_POINTS`` show the top."""
    if obj.exact_shape or obj.points is None or len(obj.points) == 0:
        return None
    heights = room.floor_distance(points_in_box(obj))
    top = seen_top(heights)
    if top is None:
        return None
    band = heights[(heights >= top - 2.0 * TOP_BIN) & (heights <= top)]  # a surface may straddle two bins
    if len(band) < MIN_POINTS:
        return None  # too few to say where the top is (sparse points spread over the object)
    return float(np.percentile(band, TOP_UPPER_PERCENTILE)), float(np.percentile(band, TOP_SPREAD_PERCENTILE))


def bounded_floor_snap(state: LayoutState, child: InstanceId, full_pose: NDArray) -> tuple[NDArray, float, str | None]:
    """World pose [4, 4] of ``child`` between its registered height and ``full_pose`` (its full floor snap)
    whose mesh box explains the most of its observed points, the fraction of the snap taken (0 to 1), and the
    reason when the snap was capped at the seen top (None otherwise).

    No height lowers the mesh's top below the lower edge of the spread of the top the capture saw
    (``seen_top_band``; not below its registered top when that lies below the upper edge): a mesh too
    short for its object, registered on the top the camera saw (a counter seen from above, 1.6 cm short of the
    floor), keeps its seen top, where its children stand, and gets a base under it instead. Within that, the
    allowed move takes the full snap's place: all of it when the points are explained there as well as at any
    allowed height (the mesh comes down until its top meets the seen top), else the smallest move within
    FIT_TIE of the best."""
    room = state.room
    obj = state.objects[child]
    verts = obj.world_vertices(full_pose)
    registered_bottom = float(room.floor_distance(obj.world_vertices()).min())
    snapped_bottom = float(room.floor_distance(verts).min())
    drop = registered_bottom - snapped_bottom  # > 0: the snap moves the object down
    limit, capped = 1.0, None
    seen = seen_top_band(obj, room) if drop > 0 else None
    if seen is not None:
        upper, low = seen
        top = float(room.floor_distance(verts).max())  # the mesh's top at the full snap
        registered_top = top + drop
        # a top registered at or below where the points show the top stays; a higher one may come down to the
        # lower edge of their spread
        keep = min(registered_top, low) if registered_top > upper else registered_top
        if top < keep:  # at (1 - t) * drop above the full snap the top is at keep
            limit = float(np.clip(1.0 - (keep - top) / drop, 0.0, 1.0))
            capped = (
                f"the full snap would lower the mesh's top {upper - top:.3f} m below the top its observed points "
                f"show ({upper:.3f} m): {limit:.0%} of it taken, a base fills the rest"
            )
    candidates = []
    for k in range(SNAP_STEPS):
        taken = limit * k / (SNAP_STEPS - 1)
        pose = translation((1.0 - taken) * drop * room.up) @ full_pose
        candidates.append((points_fit(obj, pose) or 0.0, taken, pose))
    best = max(fit for fit, _, _ in candidates)
    if candidates[-1][0] >= best - FIT_TIE:  # the largest snap allowed explains the points as well
        return (full_pose, 1.0, None) if capped is None else (candidates[-1][2], limit, capped)
    # in order of the move taken: the first within FIT_TIE of the best is the smallest such move
    fit, taken, pose = next(c for c in candidates if c[0] >= best - FIT_TIE)
    return pose, taken, capped


def _outline(
    state: LayoutState, i: InstanceId, verts: NDArray, bottom: float, band: float = BASE_LOW_BAND
) -> Polygon | None:
    """Horizontal outline (world xy) of the base of object i, whose world vertices are ``verts`` [v, 3] with
    their lowest point ``bottom`` m above the floor (see the module docstring); ``band``: how far (m) above
    the bottom the observed points that outline it may reach."""
    room, obj = state.room, state.objects[i]
    mesh_fp = footprint(verts)
    outline = None
    if obj.points is not None and len(obj.points):
        pts = apply(state.pose(i) @ inverse(obj.world_from_asset), np.asarray(obj.points, np.float64))
        low = pts[room.floor_distance(pts) < bottom + band]
        low = low[shapely.contains_xy(mesh_fp.buffer(0.02), low[:, 0], low[:, 1])]
        if len(low) >= BASE_MIN_POINTS:
            hull = MultiPoint(low[:, :2]).convex_hull
            outline = hull.intersection(mesh_fp) if isinstance(hull, Polygon) else None
    if outline is None or outline.is_empty or outline.area < BASE_MIN_AREA:
        lowest = verts[room.floor_distance(verts) < bottom + BASE_LOW_BAND]
        hull = MultiPoint(lowest[:, :2]).convex_hull
        outline = hull if isinstance(hull, Polygon) else hull.buffer(0.02)
    if outline.area < BASE_MIN_AREA:
        outline = outline.centroid.buffer(np.sqrt(BASE_MIN_AREA / np.pi))
    hull = outline.convex_hull
    return hull if isinstance(hull, Polygon) and not hull.is_empty else None


def cut_vertices(state: LayoutState, i: InstanceId) -> NDArray[np.float64]:
    """World vertices [v, 3] of object i's mesh cut as its ``cut`` completions say."""
    obj = state.objects[i]
    cuts = [c for c in state.completions.get(i, ()) if c.kind is CompletionKind.CUT]
    return apply(state.pose(i), cut_mesh(obj.vertices, obj.faces, cuts)[0]) if cuts else state.vertices(i)


def _occupied(state: LayoutState, i: InstanceId, outline: Polygon, top: float) -> list[NDArray[np.float64]]:
    """Per neighbour of object i whose geometry lies within ``outline`` (world xy, grown by BASE_CLEARANCE)
    below ``top`` (m above the floor): the xy [n, 2] of its mesh's vertices and surface samples and of its
    bases' points and surface samples there. Objects i carries or rests on are not neighbours."""
    room = state.room
    grown = outline.buffer(BASE_CLEARANCE)
    x0, y0, x1, y1 = grown.bounds
    out = []
    for j in sorted(state.objects):
        if j == i or state.forest.related(i, j):
            continue
        obj = state.objects[j]
        cuts = [c for c in state.completions.get(j, ()) if c.kind is CompletionKind.CUT]
        verts, faces = cut_mesh(obj.vertices, obj.faces, cuts) if cuts else (obj.vertices, obj.faces)
        world = apply(state.pose(j), np.asarray(verts, np.float64))
        lo, hi = world.min(axis=0), world.max(axis=0)
        solids = (
            [trimesh.Trimesh(world, faces, process=False)]
            if lo[0] <= x1 and hi[0] >= x0 and lo[1] <= y1 and hi[1] >= y0
            else []
        )
        for c in state.completions.get(j, ()):
            if c.kind is CompletionKind.BASE:
                solids.append(trimesh.convex.convex_hull(apply(state.pose(j), c.points_asset)))
        parts = [np.zeros((0, 3))]
        for solid in solids:
            parts.append(np.asarray(solid.vertices, np.float64))
            if solid.area > 0:
                parts.append(np.asarray(solid.sample(NEIGHBOUR_SAMPLES, seed=0), np.float64))
        pts = np.vstack(parts)
        pts = pts[room.floor_distance(pts) < top]
        pts = pts[shapely.contains_xy(grown, pts[:, 0], pts[:, 1])]
        if len(pts):
            out.append(pts[:, :2])
    return out


def _half_plane(direction: NDArray, level: float, reach: float) -> Polygon:
    """The half-plane {x : direction . x <= level} (world xy) as a square of side 2 ``reach`` (m)."""
    d = np.asarray(direction, np.float64) / float(np.linalg.norm(direction))
    t = np.array([-d[1], d[0]])
    c = level * d
    return Polygon([c + reach * t, c - reach * t, c - reach * t - 2 * reach * d, c + reach * t - 2 * reach * d])


def clear_of_neighbours(
    state: LayoutState, i: InstanceId, outline: Polygon, top: float
) -> tuple[Polygon | None, list[tuple[NDArray, float]]]:
    """The base ``outline`` (convex, world xy) of object i reaching ``top`` m above the floor, cut so that it
    keeps BASE_CLEARANCE from every neighbour's mesh and bases below that height (``_occupied``): per
    neighbour that reaches into it, the vertical plane at the neighbour's nearest geometry that keeps the
    largest part of the outline (of the outline's edge normals and CLEAR_DIRECTIONS horizontal directions).
    Returns the outline (None when less than BASE_MIN_AREA is left) and the cuts made, each (direction [2],
    level): the base keeps direction . xy <= level."""
    cuts: list[tuple[NDArray, float]] = []
    reach = 10.0 + float(np.abs(np.asarray(outline.bounds)).max())
    for pts in _occupied(state, i, outline, top):
        inside = pts[shapely.contains_xy(outline.buffer(BASE_CLEARANCE), pts[:, 0], pts[:, 1])]
        if not len(inside):
            continue
        ring = np.asarray(outline.exterior.coords)
        edges = np.diff(ring, axis=0)
        normals = np.c_[edges[:, 1], -edges[:, 0]]
        normals = normals[np.linalg.norm(normals, axis=1) > 1e-9]
        angles = np.arange(CLEAR_DIRECTIONS) * 2.0 * np.pi / CLEAR_DIRECTIONS
        directions = np.vstack([normals, -normals, np.c_[np.cos(angles), np.sin(angles)]])
        directions /= np.linalg.norm(directions, axis=1)[:, None]
        best: tuple[float, Polygon, NDArray, float] | None = None
        for d in directions:
            level = float((inside @ d).min()) - BASE_CLEARANCE
            kept = outline.intersection(_half_plane(d, level, reach))
            area = float(kept.area)
            if best is None or area > best[0]:
                best = (area, kept, d, level)
        assert best is not None
        area, kept, d, level = best
        if area < BASE_MIN_AREA or not isinstance(kept, Polygon):
            return None, cuts
        outline = kept
        cuts.append((d, level))
    return outline, cuts


AMODAL_STRAY_SHARE = 0.01
"""Share of an object's observed points at either end of their heights left aside as strays when the object
is tested as seen only from above."""


def seen_only_from_above(state: LayoutState, i: InstanceId) -> float | None:
    """The height (m above the floor, at the final pose) of the lowest observed point of object i when its
    points show nothing below a top (module docstring, item 3), else None."""
    cfg = state.config
    obj = state.objects[i]
    if cfg.amodal_top_band_m is None or obj.points is None or len(obj.points) < BASE_MIN_POINTS:
        return None
    pts = apply(state.pose(i) @ inverse(obj.world_from_asset), np.asarray(obj.points, np.float64))
    low, high = np.quantile(state.room.floor_distance(pts), [AMODAL_STRAY_SHARE, 1.0 - AMODAL_STRAY_SHARE])
    if high - low > cfg.amodal_top_band_m or low < cfg.amodal_min_height_m:
        return None
    return float(low)


def add_bases(state: LayoutState) -> None:
    """Add a base completion to every object in ``state.base_wanted`` that its final pose leaves above the
    floor (module docstring, items 2 and 3), and to every object in ``state.support_base_wanted`` that it
    leaves above its support's level (item 4)."""
    room = state.room
    if abs(room.up[2]) < 1e-9:
        return
    for i, reason in sorted(state.base_wanted.items()):
        _add_base(state, i, reason, 0.0, on_floor=True)
    for i, (parent, above_parent_bottom, reason) in sorted(state.support_base_wanted.items()):
        level = float(room.floor_distance(state.vertices(parent)).min()) + above_parent_bottom
        _add_base(state, i, reason, level, on_floor=False)


def _add_base(state: LayoutState, i: InstanceId, reason: str, level: float, on_floor: bool) -> None:
    """A base under object i from ``level`` (m above the floor: 0, or its support's top) up BASE_OVERLAP
    into its mesh, when its final pose leaves a gap of at least BASE_MIN_GAP. On the floor an object seen
    only from above gets its whole footprint (item 3); on a support the base is outlined by the points seen
    below the mesh only (a stem, not the shade's rim)."""
    room = state.room
    verts = cut_vertices(state, i)
    bottom = float(room.floor_distance(verts).min())
    if bottom - level < BASE_MIN_GAP:
        return
    top = bottom + BASE_OVERLAP
    seen_low = seen_only_from_above(state, i) if on_floor else None
    outline: Polygon | None
    if seen_low is None:
        outline = _outline(state, i, verts, bottom, BASE_LOW_BAND if on_floor else 0.0)
    else:
        outline, top = footprint(verts), max(top, seen_low)
        reason = (
            f"seen only from above (its observed points within {state.config.amodal_top_band_m:g} m of its top, "
            f"the lowest {seen_low:.2f} m above the floor): amodal completion, its body down to the floor "
            "under its whole footprint"
        )
    if outline is None:
        return
    outline, cleared = clear_of_neighbours(state, i, outline, top)
    if outline is None:
        state.log(i, "completions", "no base", reason="neighbours fill the space under the object")
        return
    if cleared:
        state.log(i, "completions", "base clear of neighbours", cuts=len(cleared))
    ring = np.asarray(outline.exterior.coords)[:-1]
    flat = np.c_[ring, np.zeros(len(ring))]
    offset = room.floor_distance(flat)  # height of z = 0 above the floor at each ring point
    up_z = float(room.up[2])
    low_ring = np.c_[ring, (level - offset) / up_z]
    top_ring = np.c_[ring, (top - offset) / up_z]
    world = np.vstack([low_ring, top_ring])
    points_asset = apply(inverse(state.pose(i)), world)
    state.add_completion(Completion(i, CompletionKind.BASE, points_asset, reason))


CONTACT_BAND = 0.01
"""Mesh vertices within this distance (m) of the floor are what an object stands on."""
TIPPING_MARGIN = 0.02
"""An object stands when its footprint centre lies at least this far (m) inside what it stands on."""
UNDERSIDE_BAND = 0.25
"""A tipping object's base reaches up to this share of its height: its lower part, projected to the floor."""


def add_tipping_bases(state: LayoutState) -> None:
    """A base under a generated object resting on the floor whose mesh (with the base ``add_bases`` gave it,
    if any) touches the floor only at an edge (its footprint centre more than TIPPING_MARGIN outside the hull
    of its vertices within CONTACT_BAND of the floor: a single-view completion with a sloped underside, a bed
    that would tip over in a simulator, a cabinet whose points showed the gap under its front only).
    The base is the convex hull of the mesh's lower part (vertices within UNDERSIDE_BAND of its height above
    its bottom) and of its whole footprint (cut as the object is cut) on the floor: it fills under the object
    without reaching beyond its footprint, and is not added where another object reaches into that space."""
    room = state.room
    if abs(room.up[2]) < 1e-9:
        return
    for child, edge in state.forest.edges.items():
        obj = state.objects[child]
        if obj.exact_shape or not (edge.parent is Root.FLOOR and edge.relation is Relation.RESTS_ON):
            continue
        verts = cut_vertices(state, child)
        heights = room.floor_distance(verts)
        # a base under part of it (where its points showed the gap) is part of what it stands on
        based = [
            apply(state.pose(child), c.points_asset)
            for c in state.completions.get(child, ())
            if c.kind is CompletionKind.BASE
        ]
        standing = np.vstack([verts, *based])
        standing_h = room.floor_distance(standing)
        if standing_h.min() > CONTACT_BAND:  # not on the floor at all: not this rule's case
            continue
        contact = MultiPoint(standing[standing_h <= standing_h.min() + CONTACT_BAND][:, :2]).convex_hull
        centre = footprint(verts).centroid
        inside = contact.buffer(-TIPPING_MARGIN) if isinstance(contact, Polygon) else None
        if inside is not None and not inside.is_empty and inside.contains(centre):
            continue
        low = verts[heights <= heights.min() + UNDERSIDE_BAND * float(np.ptp(heights))]
        dropped = verts - (heights / float(room.up[2]))[:, None] * np.array([0.0, 0.0, 1.0])
        world = np.vstack([low, dropped])
        top = float(room.floor_distance(low).max())
        if _under_a_neighbour(state, child, footprint(world), top):
            continue
        outline, cleared = clear_of_neighbours(state, child, footprint(world), top)
        if outline is None:
            state.log(child, "completions", "no base", reason="neighbours fill the space under the object")
            continue
        if cleared:
            hull = trimesh.convex.convex_hull(world)
            for d, level in cleared:
                normal = -np.array([d[0], d[1], 0.0])  # the side kept: d . xy <= level
                hull = hull.slice_plane(np.array([d[0] * level, d[1] * level, 0.0]), normal, cap=True)
            world = np.asarray(hull.vertices, np.float64)
            state.log(child, "completions", "base clear of neighbours", cuts=len(cleared))
        state.add_completion(
            Completion(
                child,
                CompletionKind.BASE,
                apply(inverse(state.pose(child)), world),
                "the generated mesh touches the floor only at an edge (its centre beyond what it stands on): "
                "a base under its lower part",
            )
        )


def _under_a_neighbour(state: LayoutState, i: InstanceId, outline: Polygon, top: float) -> bool:
    """Whether another object (not in i's subtree) reaches into ``outline`` [world xy] below ``top`` (m above
    the floor): a base there would fill space it stands in (a chair tucked under a desk)."""
    own = set(state.forest.subtree(i))
    for j in state.objects:
        if j in own:
            continue
        verts = state.vertices(j)
        if float(state.room.floor_distance(verts).min()) >= top:
            continue
        if outline.intersection(footprint(verts)).area > 0.01 * outline.area:
            return True
    return False


def planes_within_room(state: LayoutState) -> None:
    """Clip every support plane to the floor polygon at its object's final pose (in place, logged).

    A plane grown under a child reaches where the child was registered; a child registered through a wall
    (with its parent, 0.8 m deep) would leave the board outside the room after its parent was brought in.
    Nothing stands there, so the part beyond the floor polygon is dropped, and a plane wholly outside goes."""
    room = state.room
    if room.polygon is None or abs(room.up[2]) < 1e-9:
        return
    grown = room.polygon.buffer(state.config.containment_tolerance)
    for i, completions in sorted(state.completions.items()):
        pose = state.pose(i)
        kept: list[Completion] = []
        for c in completions:
            if c.kind is not CompletionKind.SUPPORT_PLANE or len(c.points_asset) < 3:
                kept.append(c)
                continue
            world = apply(pose, c.points_asset)
            plane = MultiPoint(world[:, :2]).convex_hull
            if not isinstance(plane, Polygon) or plane.within(grown):
                kept.append(c)
                continue
            inside = plane.intersection(room.polygon)
            if not isinstance(inside, Polygon) and not inside.is_empty:
                inside = max(getattr(inside, "geoms", []), key=lambda g: g.area, default=inside)
            hull = inside.convex_hull if not inside.is_empty else inside
            if not isinstance(hull, Polygon) or hull.is_empty or hull.area <= 0:
                state.log(i, "completions", "support plane outside the room", source=c.source)
                continue
            height = float(room.floor_distance(world).mean())
            clipped = room.at_height(np.asarray(hull.exterior.coords)[:-1], height)
            kept.append(Completion(c.instance, c.kind, apply(inverse(pose), clipped), c.source))
            state.log(
                i,
                "completions",
                "support plane clipped to the room",
                source=c.source,
                area_removed_m2=float(plane.area - hull.area),
            )
        state.completions[i] = kept


WALL_REACH_BAND = 0.03
"""An object's observed points reach its wall when their WALL_REACH_QUANTILE quantile of distances to it is
within this (m): the capture saw the object extend back to the wall (a wall cabinet's underside seen from
below), not only the face its generated mesh shows."""
WALL_REACH_QUANTILE = 0.02
"""See WALL_REACH_BAND (the nearest points, a few strays aside)."""


def add_wall_bases(state: LayoutState) -> None:
    """A base between the wall and every object in ``state.wall_base_wanted`` whose generated mesh its final
    pose leaves off that wall while its observed points reach it (WALL_REACH_BAND).

    A wall cabinet seen from below by a head-mounted camera shows its doors and its underside; a single-view
    generator makes a slab of the doors, registered where the doors were seen, 0.3 m in front of the wall. The
    wall rule cannot move it back (its points would be left outside the mesh), so it hangs on nothing. Its
    body is completed back to the wall: a convex solid spanning the mesh's outline on the wall plane (along
    the wall and up), from the wall to BASE_OVERLAP into the mesh, a ``base`` completion like the floor's
    (contact metrics count it, exporters add it as a collider). Not added where another object (not one it
    carries) reaches into that space."""
    room = state.room
    for i, (wall_id, reason) in sorted(state.wall_base_wanted.items()):
        wall = room.wall(wall_id)
        obj = state.objects[i]
        if wall is None or obj.exact_shape or obj.points is None or len(obj.points) < BASE_MIN_POINTS:
            continue
        verts = cut_vertices(state, i)
        dist = wall.distance(verts)
        gap = float(dist.min())
        if gap < BASE_MIN_GAP:
            continue
        pts = apply(state.pose(i) @ inverse(obj.world_from_asset), np.asarray(obj.points, np.float64))
        reach = float(np.quantile(wall.distance(pts), WALL_REACH_QUANTILE))
        if reach > WALL_REACH_BAND:
            state.log(i, "completions", "no wall base", reason=f"its points keep {reach:.3f} m off its wall")
            continue
        on_wall = verts - dist[:, None] * wall.normal[None, :]  # the mesh projected on the wall plane
        solid = np.vstack([on_wall, on_wall + (gap + BASE_OVERLAP) * wall.normal[None, :]])
        hull = trimesh.convex.convex_hull(solid)
        hull, cleared = _clear_along_wall(state, i, hull, wall)
        if hull is None:
            state.log(i, "completions", "no wall base", reason="neighbours fill the space behind the object")
            continue
        if cleared:
            state.log(i, "completions", "wall base clear of neighbours", neighbours=cleared)
        world = np.asarray(hull.vertices, np.float64)
        state.add_completion(
            Completion(
                i,
                CompletionKind.BASE,
                apply(inverse(state.pose(i)), world),
                f"its mesh keeps {gap:.2f} m off its wall while its observed points reach the wall ({reason}): "
                "amodal completion, its body back to the wall",
            )
        )


WALL_BASE_MIN_KEPT = 0.5
"""A wall base cut clear of its neighbours keeps at least this share of its volume, or is not added."""


def _clear_along_wall(
    state: LayoutState, i: InstanceId, hull: trimesh.Trimesh, wall
) -> tuple[trimesh.Trimesh | None, list[int]]:
    """The wall base ``hull`` (world) of object i cut clear of every neighbour (not in i's subtree or carrying
    it) whose mesh reaches into it by more than BASE_CLEARANCE: per such neighbour, of the planes along the
    wall and up or down at BASE_CLEARANCE before its vertices inside, the one keeping the most volume (the
    other half of an over-segmented cabinet beside it, a cabinet below). Returns the cut hull (None when
    less than WALL_BASE_MIN_KEPT of it is left) and the neighbours cut for."""
    volume = float(hull.volume)
    cleared: list[int] = []
    for j in sorted(state.objects):
        if j == i or state.forest.related(i, j):
            continue
        verts = state.vertices(j)
        lo, hi = hull.bounds
        near = verts[np.all((verts >= lo - BASE_CLEARANCE) & (verts <= hi + BASE_CLEARANCE), axis=1)]
        if not len(near):
            continue
        inside = near[trimesh.proximity.signed_distance(hull, near) > BASE_CLEARANCE]
        if not len(inside):
            continue
        best: trimesh.Trimesh | None = None
        for d in (wall.tangent, -wall.tangent, state.room.up, -state.room.up):
            level = float((inside @ d).min()) - BASE_CLEARANCE
            kept = hull.slice_plane(level * d, -d, cap=True)
            if kept is not None and len(kept.vertices) >= 4 and (best is None or kept.volume > best.volume):
                best = kept
        if best is None or best.volume < WALL_BASE_MIN_KEPT * volume:
            return None, cleared
        hull = trimesh.convex.convex_hull(np.asarray(best.vertices, np.float64))
        cleared.append(int(j))
    return hull, cleared
