"""Cut a generated mesh's completion where it reaches through the floor, a wall or a neighbour and its
points do not.

A single-view completion is often deeper or taller than its object (a desk 0.17 m too deep, a sofa 0.1 m
too tall). Registered on the object's points, its seen side is where the capture saw it and the surplus
pokes through the wall behind it or the floor below it. The rules would repair such a crossing by moving
the whole object off its points (a footprint step of 5 cm away from the wall, a floor snap lifting it
6 cm), although the capture saw the wall and the floor and nothing of the object beyond them: the surplus
is the generator's, not the pose's. So before the rules run, each generated asset with observed points is
cut at the floor and at every wall whose segment it stands in front of, where its mesh reaches more than
TRIM_MARGIN beyond both the boundary and its own points (the cut plane lies at the boundary, or at the
points' own reach when registration put some of them beyond it, through a wall at most BEHIND_WALL_NOISE:
points further behind a wall the capture saw are strays). The cut keeps the side facing into the
room, capped so a closed mesh stays closed, and is a ``Completion`` of kind ``cut`` in the object's asset
frame, so exporters and metrics cut the same mesh. A cut that would keep less than MIN_KEPT_SHARE of the
mesh's extent across the plane is not made: then the pose, not the completion, is wrong, and the rules
repair it.

After depenetration (which moves a generated object only as far as its points allow), two completions
may still fill the same space (a tucked chair and a desk whose completion filled the space between its
legs): ``cut_overlaps`` cuts the one that was not seen there, or, when both were seen near it, the one that
can be cut just clear of the space both meshes fill at the least cost in its points. Neither object moves.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely
import trimesh
from numpy.typing import NDArray

from rescene_core.assembly.collision import CollisionWorld
from rescene_core.assembly.graph import Forest
from rescene_core.assembly.objects import AssemblyObject
from rescene_core.assembly.room import Room
from rescene_core.assembly.state import LayoutState
from rescene_core.geometry.completion import cut_mesh
from rescene_core.geometry.sim3 import apply, inverse
from rescene_core.records import Completion, CompletionKind, InstanceId, Relation, Root

TRIM_MARGIN = 0.01
"""How far (m) a mesh must reach beyond a boundary, and beyond its own points, to be cut."""
POINTS_REACH_PERCENTILE = 1.0
"""The points' reach towards a boundary is this percentile of their distances to it (stray points aside)."""
MIN_KEPT_SHARE = 0.5
"""Smallest share of the mesh's extent across a cut plane the cut may keep."""
MIN_POINTS = 20
"""Fewest observed points for a cut (fewer say too little about where the object ends)."""


BEHIND_WALL_NOISE = 0.02
"""Observed points further than this (m) behind a wall the capture saw are strays: nothing behind a seen wall
can be seen from inside the room. The points' reach through a wall counts up to this far (depth noise and the
wall's own fit). On cluttered diagnostic seed 201 the 1st percentile of a cabinet's, a bookshelf's and a wall
shelf's points lay 6-7 cm behind their wall, the registered mesh fitted to it, the ground-truth meshes 0-4 mm
in front of the wall; the floor rule keeps the points' whole reach (a floor plane estimated a few centimetres
high)."""


def _plane(reach_points: float, distances_mesh: NDArray, span: float) -> float | None:
    """Signed distance (m, from the boundary, positive inside) of the cut plane, or None: no cut."""
    level = min(0.0, reach_points)
    deepest = float(distances_mesh.min())
    if deepest >= level - TRIM_MARGIN:
        return None
    if float(distances_mesh.max()) - level < MIN_KEPT_SHARE * span:
        return None
    return level


def room_cuts(obj: AssemblyObject, room: Room) -> list[Completion]:
    """The cuts of a generated asset with points at its registered pose (module docstring); [] for exact
    shapes and objects without enough points."""
    if obj.exact_shape or obj.points is None or len(obj.points) < MIN_POINTS:
        return []
    pose = np.asarray(obj.world_from_asset, np.float64)
    verts = obj.world_vertices()
    pts = np.asarray(obj.points, np.float64)
    cuts: list[tuple[NDArray, NDArray, str]] = []
    heights = room.floor_distance(verts)
    level = _plane(
        float(np.percentile(room.floor_distance(pts), POINTS_REACH_PERCENTILE)), heights, float(np.ptp(heights))
    )
    if level is not None:
        origin = verts[int(np.argmin(heights))] + (level - float(heights.min())) * room.up
        cuts.append((origin, room.up, "floor"))
    for wall in room.walls:
        along = wall.along(verts)
        if along.max() <= 0.0 or along.min() >= wall.length:
            continue  # not in front of this wall's segment
        dist = wall.distance(verts)
        reach = max(float(np.percentile(wall.distance(pts), POINTS_REACH_PERCENTILE)), -BEHIND_WALL_NOISE)
        level = _plane(reach, dist, float(np.ptp(dist)))
        if level is None:
            continue
        origin = verts[int(np.argmin(dist))] + (level - float(dist.min())) * wall.normal
        cuts.append((origin, wall.normal, f"wall {wall.id}"))
    return [
        cut_plane(
            obj.instance,
            pose,
            origin,
            normal,
            f"the generated mesh reaches through the {what} beyond the object's observed points: cut there",
        )
        for origin, normal, what in cuts
    ]


TOP_BIN = 0.02
"""Height bin (m) of a parent's points when its observed top is looked for."""
TOP_MIN_SHARE = 0.2
"""The observed top is the upper edge of the highest bin holding at least this share of the fullest bin's
points (and TOP_MIN_COUNT): bleed from what stands on the parent is sparse; a seen top surface is dense, and
a side panel seen up to the top spreads its points evenly over every height."""
TOP_MIN_COUNT = 3
TOP_WINDOW = 0.05
"""A parent seen more than this (m) above where its children stand has more than a top there (shelves)."""


def seen_top(heights: NDArray) -> float | None:
    """Observed top (m above the floor) of points at ``heights`` [n] (TOP_MIN_SHARE), or None."""
    if len(heights) < MIN_POINTS:
        return None
    edges = np.arange(float(heights.min()), float(heights.max()) + TOP_BIN, TOP_BIN)
    if len(edges) < 2:
        return float(heights.max())
    counts, edges = np.histogram(heights, bins=edges)
    dense = np.flatnonzero(counts >= max(TOP_MIN_COUNT, TOP_MIN_SHARE * counts.max()))
    return float(edges[dense[-1] + 1]) if dense.size else None


def top_cuts(objects: dict[InstanceId, AssemblyObject], forest: Forest, room: Room) -> dict[InstanceId, Completion]:
    """Cuts of generated parents taller than what stands on them and what was seen of them, at the registered
    poses.

    A single-view completion is often too tall (a nightstand 15 cm taller than it is). Its children were
    registered on their own points standing on the real top, so the solver lifted them onto the invented one.
    When every child resting on a generated parent was registered with its bottom more than TRIM_MARGIN below
    the parent's mesh top, and the parent's observed top (``seen_top``) lies at most TOP_WINDOW above the
    highest of those bottoms, the mesh is cut at the higher of that bottom and the observed top, keeping the
    side below; not when the cut would keep less than MIN_KEPT_SHARE of its height. Children registered above
    the mesh top do not count (they stand on something else, or float). Returns parent -> ``cut`` completion
    (asset frame)."""
    children: dict[InstanceId, list[InstanceId]] = {}
    for child, edge in forest.edges.items():
        if edge.relation is Relation.RESTS_ON and not isinstance(edge.parent, Root) and edge.parent in objects:
            children.setdefault(InstanceId(edge.parent), []).append(child)
    out = {}
    for parent, kids in sorted(children.items()):
        obj = objects[parent]
        if obj.exact_shape or obj.points is None or len(obj.points) < MIN_POINTS:
            continue
        verts = obj.world_vertices()
        heights = room.floor_distance(verts)
        top, low = float(heights.max()), float(heights.min())
        bottoms = [float(room.floor_distance(objects[k].world_vertices()).min()) for k in kids]
        bottoms = [b for b in bottoms if b <= top + TOP_WINDOW]
        if not bottoms or max(bottoms) >= top - TRIM_MARGIN:
            continue  # a child stands on the top
        observed = seen_top(room.floor_distance(np.asarray(obj.points, np.float64)))
        if observed is None or observed > max(bottoms) + TOP_WINDOW:
            continue
        level = max(max(bottoms), observed)
        if top - level <= TRIM_MARGIN or level - low < MIN_KEPT_SHARE * (top - low):
            continue
        origin = verts[int(np.argmax(heights))] - (top - level) * room.up
        out[parent] = cut_plane(
            parent,
            obj.world_from_asset,
            origin,
            -room.up,
            f"the generated mesh reaches {top - level:.2f} m above where its children stand and its points end: "
            "cut there",
        )
    return out


SEAT_REACH = 0.03
"""A generated child's points reach down to what it stands on when their reach (POINTS_REACH_PERCENTILE of
their heights) lies within this distance (m) of its parent's surface seen around it (SEAT_AROUND)."""
SEAT_AROUND = 0.05
"""How far (m) around a child's footprint its parent's points show the surface it stands on."""
SEAT_SINK_MIN = 0.003
"""A generated child's mesh reaching at least this far (m) into the top its support was seen with around it
is cut at that top (``seat_cuts``); less is depth noise and marching-cubes steps. 3 mm: the top read around a
child (``compile_support.surface_height``) is within 2.5 mm of the truth for 168 of 176 children on
egocentric seeds 200-209 and 0-4 (5 mm while the band's upper quartile read it, 52 of 181 beyond 2.5 mm)."""
SEAT_SINK_MAX_POINTS = 0.2
"""... unless more than this share of the child's points (within ``evidence.SEEN_BOX_MARGIN`` of its mesh box)
lie below that top: bleed of the top at the child's foot and depth noise are 2-16 % on egocentric diagnostic
seeds 205-206; a bowl generated as a disc at its rim had 22 % below the layer its own points make in its
parent's."""


def levelled_for_seat(obj: AssemblyObject, seen: NDArray, room: Room) -> AssemblyObject:
    """``obj`` as the rules will stand it when it was registered more than ``evidence.LEVEL_REFIT_MIN_TILT_DEG``
    tilted: its +z axis turned onto the floor normal about the median of its points ``seen`` [k, 3] (its
    bounding-box centre with fewer than ``evidence.LEVEL_PIVOT_MIN_POINTS``), as ``evidence.levelling`` turns a
    generated asset about ``evidence.level_pivot``; else ``obj`` itself. A horizontal plane through a tilted
    mesh cuts a wedge off it, not its bottom."""
    from rescene_core.assembly.evidence import LEVEL_PIVOT_MIN_POINTS, LEVEL_REFIT_MIN_TILT_DEG
    from rescene_core.assembly.transforms import level_correction

    pose = np.asarray(obj.world_from_asset, np.float64)
    verts = obj.world_vertices()
    pivot = np.median(seen, axis=0) if len(seen) >= LEVEL_PIVOT_MIN_POINTS else 0.5 * (verts.min(0) + verts.max(0))
    correction, tilt = level_correction(pose, room.up, pivot, np.pi, candidates=(2,))
    if np.degrees(tilt) <= LEVEL_REFIT_MIN_TILT_DEG:
        return obj
    return replace(obj, world_from_asset=correction @ pose)


def seat_cuts(
    objects: dict[InstanceId, AssemblyObject],
    forest: Forest,
    room: Room,
    seats: dict[InstanceId, float] | None = None,
) -> dict[InstanceId, list[Completion]]:
    """Cuts of generated children resting on objects whose mesh reaches below where their points show them
    standing, or into the top their support was seen with around them, at the registered poses.

    A single-view completion of a small object is often taller than it (egocentric diagnostic seeds 201 and
    203: cups, jars and cutting boards 1-8 cm taller), registered on its points with the surplus below the
    bottom the capture saw (1-3 cm) and above its top. The support rule then put the mesh's lowest point on
    its parent's face, lifting the object by that surplus. When the child's points (those within
    ``evidence.SEEN_BOX_MARGIN`` of its mesh box) reach down to within SEAT_REACH of its parent's surface (at
    least MIN_POINTS of the parent's points within SEAT_AROUND of its footprint at that height: the bottom
    was seen where the parent was seen, not only a rim or a top; the parent's mesh may still be tilted or
    off) and its mesh reaches more than TRIM_MARGIN below them, the mesh is cut at the points' reach, keeping
    the side above; not when the cut would keep less than MIN_KEPT_SHARE of its height.

    *Into the seen top* (``SEAT_SINK_MIN``): otherwise, when the top the parent's points show around the
    child (``compile_support.top_seen_around``: a dense surface at the child's bottom, no denser layer above
    it) lies at least SEAT_SINK_MIN and at most SEAT_REACH above the child's mesh bottom, the mesh is cut at
    that top: nothing of the child can have been seen inside its support, so the part below the surface is
    the generator's surplus, and the support rule would lift the object by it (egocentric diagnostic seeds
    204-207: cups, jars and cutting boards registered 5-14 mm into their counter or island, lifted as much,
    their centre error 0.004-0.009 -> 0.010-0.017 m; the child's lowest points are the parent's bleed, so the
    cut above does not see it). Not when more than SEAT_SINK_MAX_POINTS of its points lie below that top (the
    surface is the child's own: a bowl generated as a disc at its rim).

    A child registered more than ``evidence.LEVEL_REFIT_MIN_TILT_DEG`` tilted is cut as the rules will stand
    it, levelled about its seen points (``levelled_for_seat``): a horizontal plane through the tilted mesh
    would cut a wedge off it, and once levelled its too tall completion stood on its support (spice jars
    registered 30-40 deg tilted on egocentric diagnostic seeds 205-206, their centre 1-3 cm above the truth).

    Either way the mesh is also cut at the points' upper reach when it reaches more than TRIM_MARGIN above
    it. Returns child -> ``cut`` completions (asset frame); ``seats``, when given, receives child -> the seen
    top (m above the floor) of each child cut into it, where the support rule seats it
    (``LayoutState.seen_seats``)."""
    from rescene_core.assembly.compile_support import top_seen_around
    from rescene_core.assembly.evidence import points_in_box
    from rescene_core.assembly.objects import footprint

    out = {}
    carrying = {InstanceId(edge.parent) for edge in forest.edges.values() if not isinstance(edge.parent, Root)}
    for child, edge in sorted(forest.edges.items()):
        if edge.relation is not Relation.RESTS_ON or isinstance(edge.parent, Root) or edge.parent not in objects:
            continue
        if child in carrying:
            continue  # a support's level is where its own children were seen standing (``top_cuts``)
        obj = objects[child]
        if obj.exact_shape or obj.points is None or len(obj.points) < MIN_POINTS:
            continue
        seen = points_in_box(obj)
        if len(seen) < MIN_POINTS:
            continue
        parent = objects[InstanceId(edge.parent)]
        if parent.points is None or len(parent.points) < MIN_POINTS:
            continue
        # a child registered tilted is cut where the rules will stand it: levelled about its seen points
        at = levelled_for_seat(obj, seen, room)
        verts = at.world_vertices()
        heights = room.floor_distance(verts)
        low, top = float(heights.min()), float(heights.max())
        reach = float(np.percentile(room.floor_distance(seen), POINTS_REACH_PERCENTILE))
        seat = None
        if reach - low > TRIM_MARGIN and top - reach >= MIN_KEPT_SHARE * (top - low):
            around = footprint(verts).buffer(SEAT_AROUND)
            pts = np.asarray(parent.points, np.float64)
            pts = pts[shapely.contains_xy(around, pts[:, 0], pts[:, 1])]
            # the parent's surface seen there: else the points may show only a rim or a top
            if int(np.count_nonzero(np.abs(room.floor_distance(pts) - reach) <= SEAT_REACH)) >= MIN_POINTS:
                seat = (
                    reach,
                    f"the generated mesh reaches {reach - low:.3f} m below where its points show it standing on its "
                    "support: cut there",
                )
        if seat is None:
            surface = top_seen_around(parent, at, room)
            if (
                surface is not None
                and SEAT_SINK_MIN <= surface - low <= SEAT_REACH
                and top - surface >= MIN_KEPT_SHARE * (top - low)
                and float(np.mean(room.floor_distance(seen) < surface)) <= SEAT_SINK_MAX_POINTS
            ):
                seat = (
                    surface,
                    f"the generated mesh reaches {surface - low:.3f} m into the top its support was seen with "
                    "around it: cut there",
                )
                if seats is not None:
                    seats[child] = surface
        if seat is None:
            continue
        level, source = seat
        origin = verts[int(np.argmin(heights))] + (level - low) * room.up
        cuts = [cut_plane(child, at.world_from_asset, origin, room.up, source)]
        upper = float(np.percentile(room.floor_distance(seen), 100.0 - POINTS_REACH_PERCENTILE))
        if top - upper > TRIM_MARGIN and upper - level >= MIN_KEPT_SHARE * (top - low):
            # seen from its bottom up, the object ends where its points end
            origin = verts[int(np.argmax(heights))] - (top - upper) * room.up
            source = (
                f"the generated mesh reaches {top - upper:.3f} m above its points, seen down to its support: cut there"
            )
            cuts.append(cut_plane(child, at.world_from_asset, origin, -room.up, source))
        out[child] = cuts
    return out


def cut_plane(
    instance: InstanceId, world_from_asset: NDArray, origin: NDArray, normal: NDArray, source: str
) -> Completion:
    """The ``cut`` completion of the world plane through ``origin`` [3] with ``normal`` [3] (the side kept),
    in the asset frame of an object at ``world_from_asset`` [4, 4]: the point and the point plus the unit
    normal there."""
    ends = apply(inverse(np.asarray(world_from_asset, np.float64)), np.stack([origin, origin + normal]))
    direction = ends[1] - ends[0]
    ends[1] = ends[0] + direction / np.linalg.norm(direction)
    return Completion(instance, CompletionKind.CUT, ends, source)


def trimmed(obj: AssemblyObject, cuts: list[Completion]) -> AssemblyObject:
    """``obj`` with its mesh cut at ``cuts`` (the asset frame and pose unchanged)."""
    if not cuts:
        return obj
    vertices, faces = cut_mesh(obj.vertices, obj.faces, cuts)
    return replace(obj, vertices=vertices, faces=faces)


OVERLAP_MAX_POINT_SHARE = 0.05
"""The mesh cut out of an overlap may hold at most this share of its object's observed points there (the
points the cut leaves outside the mesh: segmentation bleed and registration noise, not the object)."""
REGION_SAMPLES = 20000
"""Surface samples per mesh (besides its vertices) that outline where two meshes overlap."""
REGION_CLEARANCE = 0.005
"""Gap (m) a cut clearing an overlap leaves before the space both meshes fill (a cut through its corner would
still touch the other mesh)."""
HORIZONTAL_DIRECTIONS = 24
"""Horizontal directions tried for a cut clearing an overlap (besides up, down and the footprints' separating
axis)."""


def cut_overlaps(state: LayoutState, world: CollisionWorld, stage: str = "overlap cuts") -> int:
    """After depenetration (and, ``cut_registered_overlaps``, before the rules): cut the pairs of generated
    assets that still overlap. For a colliding pair the
    direction n is the separating axis of their footprints (from a into b) and the overlap is the slab between
    b's mesh start and a's mesh end along n. The object with the smaller share of its observed points in that
    slab, if at most OVERLAP_MAX_POINT_SHARE, is cut at the slab's far side: its completion filled space the
    other object was seen in. Otherwise (both were seen in the slab, or that cut would keep too little) one of
    them is cut just clear of the space both meshes fill, where it holds few of its points
    (``_cut_overlap_region``). Exact shapes and cuts keeping less than MIN_KEPT_SHARE of a mesh's extent across
    the plane are left as they are. Returns the number of pairs cut; each cut is a ``cut``
    completion."""
    from rescene_core.assembly.depenetrate import separating_vector

    cut = 0
    poses = {i: state.pose(i) for i in state.objects}
    for a, b in world.colliding_pairs(poses, skip=state.forest.related):
        oa, ob = state.objects[a], state.objects[b]
        if any(o.exact_shape or o.points is None or len(o.points) < MIN_POINTS for o in (oa, ob)):
            continue
        mtv = separating_vector(state.footprint(a), state.footprint(b))
        length = float(np.linalg.norm(mtv))
        if length < 1e-9:
            cut += _cut_overlap_region(state, a, b, None, stage)
            continue
        n = np.array([-mtv[0] / length, -mtv[1] / length, 0.0])  # from a into b
        va, vb = state.vertices(a) @ n, state.vertices(b) @ n
        lo, hi = float(vb.min()), float(va.max())  # the overlap slab along n
        if hi <= lo:
            continue
        share = {i: _points_share(state, i, n, lo, hi) for i in (a, b)}
        loser = a if share[a] <= share[b] else b
        # a keeps what lies before the slab (normal -n at lo), b what lies after it (normal n at hi)
        level, normal, verts_n = (lo, -n, va) if loser == a else (hi, n, vb)
        kept = level - verts_n.min() if loser == a else verts_n.max() - level
        keeps_bottom = _keeps_bottom(state, a, n, lo) if loser == a else _keeps_bottom(state, b, -n, -hi)
        if share[loser] > OVERLAP_MAX_POINT_SHARE or kept < MIN_KEPT_SHARE * np.ptp(verts_n) or not keeps_bottom:
            cut += _cut_overlap_region(state, a, b, n, stage)
            continue
        verts = state.vertices(loser)
        origin = verts[0] + (level - float(verts[0] @ n)) * n
        other = b if loser == a else a
        state.add_completion(
            cut_plane(
                loser,
                state.pose(loser),
                origin,
                normal,
                f"the generated mesh fills space where object {int(other)} was seen and it was not "
                f"({share[loser]:.0%} of its points there): cut there",
            )
        )
        state.log(loser, stage, "cut overlap", other=int(other), axis=n, depth_m=hi - lo, points_share=share[loser])
        cut += 1
    return cut


def cut_registered_overlaps(state: LayoutState) -> dict[InstanceId, list[Completion]]:
    """Before the rules: cut the generated assets that overlap at their registered poses (``cut_overlaps``),
    and replace each cut object's mesh in ``state`` by its cut mesh (returns the new cuts per object).

    Two generated completions registered on their own points often fill the same space: a row of kitchen
    counters whose completions are each a few centimetres wider than the counter, a desk completed into the
    chair tucked under it. Depenetration would push them apart by the whole overlap (a counter 10 cm along
    the row, off the points it was registered on, its neighbour held by its own points). The overlap is the
    generator's, not the poses': where one mesh fills space the other object was seen in and it was not, it
    is cut there, before any rule moves either. Pairs whose points overlap too are left to the rules."""
    from rescene_core.assembly.collision import CollisionWorld

    known = {i: len(c) for i, c in state.completions.items()}
    cut_overlaps(state, CollisionWorld(state.objects), "registered overlap cuts")
    new: dict[InstanceId, list[Completion]] = {}
    for i, completions in state.completions.items():
        added = [c for c in completions[known.get(i, 0) :] if c.kind is CompletionKind.CUT]
        if added:
            new[i] = added
            state.replace_object(trimmed(state.objects[i], added))
    return new


def _world_points(state: LayoutState, i: InstanceId) -> NDArray[np.float64]:
    """Observed points [n, 3] of object i, carried along with its corrections (world)."""
    obj = state.objects[i]
    return apply(state.pose(i) @ inverse(obj.world_from_asset), np.asarray(obj.points, np.float64))


def _points_share(state: LayoutState, i: InstanceId, n: NDArray, lo: float, hi: float) -> float:
    """Share of object i's observed points between ``lo`` and ``hi`` along ``n``."""
    proj = _world_points(state, i) @ n
    return float(np.mean((proj >= lo) & (proj <= hi)))


def _directions(n: NDArray | None, up: NDArray) -> list[NDArray[np.float64]]:
    """Candidate cut normals: the footprints' separating axis ``n`` (or none), up, down and horizontals."""
    up = np.asarray(up, np.float64)
    tangent = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    tangent /= np.linalg.norm(tangent)
    other = np.cross(up, tangent)
    angles = np.arange(HORIZONTAL_DIRECTIONS) * 2.0 * np.pi / HORIZONTAL_DIRECTIONS
    out = [] if n is None else [np.asarray(n, np.float64), -np.asarray(n, np.float64)]
    return out + [up, -up] + [np.cos(t) * tangent + np.sin(t) * other for t in angles]


BOTTOM_BAND = 0.01
"""Vertices within this height (m) of an object's lowest are its bottom, where it stands."""


def _keeps_bottom(state: LayoutState, i: InstanceId, d: NDArray, level: float) -> bool:
    """Whether a cut of object i keeping the side ``verts @ d <= level`` keeps some of its bottom (always, for
    an object not resting on anything): an overlap cut must not take away what a resting object stands on
    (a chair's legs under a table's completion), or it floats."""
    edge = state.forest.edges.get(i)
    if edge is None or edge.relation is not Relation.RESTS_ON:
        return True
    verts = state.vertices(i)
    heights = state.room.floor_distance(verts)
    bottom = verts[heights <= float(heights.min()) + BOTTOM_BAND]
    return bool((bottom @ np.asarray(d, np.float64) <= level).any())


def _inside(mesh: trimesh.Trimesh, points: NDArray) -> NDArray[np.bool_]:
    """Which of ``points`` [n, 3] lie inside the closed ``mesh`` (Open3D's ray-parity occupancy, C++)."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    # Open3D's stubs take no numpy array in o3d.core.Tensor (the bindings do)
    vertices = o3d.core.Tensor(np.asarray(mesh.vertices, np.float32))  # type: ignore[call-overload]
    scene.add_triangles(vertices, o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))  # type: ignore[call-overload]
    occupancy = scene.compute_occupancy(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()  # type: ignore[call-overload]
    return occupancy > 0.5


def overlap_region(
    state: LayoutState, a: InstanceId, b: InstanceId
) -> tuple[NDArray[np.float64], dict[InstanceId, NDArray[np.float64]]]:
    """Points [n, 3] outlining where the closed meshes of a and b overlap (world): each one's vertices and
    surface samples inside the other (the region's boundary, so its extreme along any direction; a mesh that
    is not closed counts as its convex hull: a generated screen's open panel), empty when they do not
    overlap; and each mesh's surface samples [REGION_SAMPLES, 3]."""
    meshes = {i: trimesh.Trimesh(state.vertices(i), state.objects[i].faces, process=True) for i in (a, b)}
    samples = {i: np.asarray(m.sample(REGION_SAMPLES, seed=0), np.float64) for i, m in meshes.items()}
    solids = {i: m if m.is_watertight else m.convex_hull for i, m in meshes.items()}
    if not all(m.is_watertight for m in solids.values()):
        return np.zeros((0, 3)), samples
    parts = [np.zeros((0, 3))]
    for i, j in ((a, b), (b, a)):
        surface = np.vstack([meshes[i].vertices, samples[i]])
        parts.append(surface[_inside(solids[j], surface)])
    return np.vstack(parts), samples


def _cut_overlap_region(
    state: LayoutState, a: InstanceId, b: InstanceId, n: NDArray | None, stage: str = "overlap cuts"
) -> int:
    """Cut one generated mesh of an overlapping pair just clear of the space both meshes fill
    (``overlap_region``), when that costs the object few of its own points: for each of the two objects and
    each direction d (``_directions``), the object keeps what lies REGION_CLEARANCE before the region's nearest
    extent along d. Of the cuts leaving at most OVERLAP_MAX_POINT_SHARE of the object's observed points outside
    and keeping at least MIN_KEPT_SHARE of its extent along d, the one removing the least of the mesh's surface
    wins; the other mesh is not touched and neither object moves. A cut never takes the whole bottom of an
    object resting on something (``_keeps_bottom``). Without such a cut, both meshes are cut across
    the region (``_split_overlap_region``). Returns 1 when the pair was cut, else 0."""
    region, surface = overlap_region(state, a, b)
    if len(region) == 0:
        return 0
    best: tuple[float, float, InstanceId, NDArray, float, float] | None = None
    for loser in (a, b):
        verts = state.vertices(loser)
        pts = _world_points(state, loser)
        for d in _directions(n, state.room.up):
            level = float((region @ d).min()) - REGION_CLEARANCE
            proj = verts @ d
            depth = float(proj.max()) - level
            if depth <= 0.0 or level - float(proj.min()) < MIN_KEPT_SHARE * float(np.ptp(proj)):
                continue
            if not _keeps_bottom(state, loser, d, level):
                continue
            share = float(np.mean(pts @ d > level))
            if share > OVERLAP_MAX_POINT_SHARE:
                continue
            removed = float(np.mean(surface[loser] @ d > level))
            if best is None or removed < best[0]:
                best = (removed, depth, loser, d, level, share)
    if best is None:
        return _split_overlap_region(state, a, b, n, region, stage)
    _, depth, loser, d, level, share = best
    other = b if loser == a else a
    verts = state.vertices(loser)
    origin = verts[0] + (level - float(verts[0] @ d)) * d
    state.add_completion(
        cut_plane(
            loser,
            state.pose(loser),
            origin,
            -d,
            f"the generated mesh fills space that object {int(other)}'s mesh fills too and holds {share:.0%} of "
            "its points beyond it: cut there",
        )
    )
    state.log(loser, stage, "cut overlap", other=int(other), axis=d, depth_m=depth, points_share=share)
    return 1


SPLIT_LEVELS = 21
"""Planes tried across the space both meshes fill, per direction, when neither mesh can give all of it up."""
SEAM_BAND = 0.02
"""Half-width (m) of the seam between two objects both seen up to a common boundary (counters in a row): an
instance mask bleeds a few pixels across the boundary and depth is noisy there, so an object's points within
this distance beyond a split plane are the seam's and do not count against the plane."""


def _split_overlap_region(
    state: LayoutState,
    a: InstanceId,
    b: InstanceId,
    n: NDArray | None,
    region: NDArray,
    stage: str = "overlap cuts",
) -> int:
    """Cut both generated meshes of an overlapping pair at one plane across the space both fill
    (``overlap_region`` points ``region``), when neither can give up all of it (``_cut_overlap_region``):
    each keeps its side, REGION_CLEARANCE / 2 back from the plane. Of the directions (``_directions``) and
    SPLIT_LEVELS planes across the region along each, those leaving at most OVERLAP_MAX_POINT_SHARE of each
    object's observed points outside its side by more than SEAM_BAND and keeping at least MIN_KEPT_SHARE of each mesh's extent
    qualify; the one losing the fewest points beyond the seam (the larger of the two shares), then the fewest
    at all, wins. Returns 1 when the pair
    was cut, 0 when no plane qualifies (the points of the two overlap there: left, with the reason logged)."""
    pts = {i: _world_points(state, i) for i in (a, b)}
    verts = {i: state.vertices(i) for i in (a, b)}
    best: tuple[tuple[float, float], NDArray, float] | None = None
    for d in _directions(n, state.room.up):
        along = region @ d
        va, vb = verts[a] @ d, verts[b] @ d
        pa, pb = pts[a] @ d, pts[b] @ d
        for level in np.linspace(float(along.min()), float(along.max()), SPLIT_LEVELS):
            keep_a, keep_b = level - 0.5 * REGION_CLEARANCE, level + 0.5 * REGION_CLEARANCE
            if keep_a - va.min() < MIN_KEPT_SHARE * np.ptp(va) or vb.max() - keep_b < MIN_KEPT_SHARE * np.ptp(vb):
                continue
            if not (_keeps_bottom(state, a, d, keep_a) and _keeps_bottom(state, b, -d, -keep_b)):
                continue
            lost = max(float(np.mean(pa > keep_a + SEAM_BAND)), float(np.mean(pb < keep_b - SEAM_BAND)))
            # among planes losing as few points beyond the seam, the one losing the fewest at all
            cost = (lost, max(float(np.mean(pa > keep_a)), float(np.mean(pb < keep_b))))
            if lost <= OVERLAP_MAX_POINT_SHARE and (best is None or cost < best[0]):
                best = (cost, d, float(level))
    if best is None:
        state.log(a, stage, "overlap left", other=int(b), reason="the two objects' points overlap there")
        return 0
    _, d, level = best
    for i, other, normal, keep in (
        (a, b, -d, level - 0.5 * REGION_CLEARANCE),
        (b, a, d, level + 0.5 * REGION_CLEARANCE),
    ):
        proj = verts[i] @ d
        depth = float(proj.max()) - keep if i == a else keep - float(proj.min())
        if depth <= 0.0:
            continue
        share = float(np.mean(pts[i] @ d > keep)) if i == a else float(np.mean(pts[i] @ d < keep))
        origin = verts[i][0] + (keep - float(verts[i][0] @ d)) * d
        state.add_completion(
            cut_plane(
                i,
                state.pose(i),
                origin,
                normal,
                f"the generated mesh fills space that object {int(other)}'s mesh fills too, both seen near it: "
                f"cut across it ({share:.0%} of its points beyond)",
            )
        )
        state.log(i, stage, "cut overlap", other=int(other), axis=d, depth_m=depth, points_share=share, split=True)
    return 1
