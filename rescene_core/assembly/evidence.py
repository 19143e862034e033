"""What the rules may trust of a generated asset: its faces' directions and its extent inside the room.

A generated asset (``AssemblyObject.exact_shape`` False) is registered to the points a camera saw, so its
registered centre and its seen faces are evidence, but (a) its asset axes follow the generator's frame,
not the object's faces, and (b) its unseen side is a completion (a single-view generator mirrors or
extrudes the seen side), often deeper than the object. Geometry that crosses a wall or leaves the floor
polygon while the object's bounding-box centre is inside the room cannot have been seen from inside the
room: it is a completion error, and moving the object by it moves a well-registered object away from
where it was seen. Since the `lift` backend stopped over-deepening its completions, most crossings are
a few centimetres of registration or size error, which the rules must repair, and the few deeper ones
(an oversized bed 0.4 m through a wall) would leave the scene unloadable: by default
(``AttachmentConfig.completion_min_excess`` None) every crossing is repaired. When it is set, a crossing
deeper than it is taken as completion evidence. For such objects:

* ``wall_gap``: the gap to a wall is the smallest distance of the mesh, but a penetration deeper than
  ``completion_min_excess`` counts as contact (gap 0) while the centre is in front of the wall;
* ``containment_footprint``: containment tests use the footprint clipped to the floor polygon while the
  centre is inside it and the footprint reaches more than ``completion_min_excess`` beyond the polygon;
* ``face_yaw``: the yaw that turns the object square to a direction is read from the mesh's vertical
  faces (area-weighted histogram of their horizontal normals, folded modulo 180 deg), not from the asset
  axes; None when no face direction holds at least ``FACE_YAW_MIN_FRACTION`` of the vertical area.

Exact shapes keep the full-mesh behaviour (and the asset-axis yaw, their frame being the object's own).
"""

from __future__ import annotations

import numpy as np
import shapely
import trimesh
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from shapely.geometry import Point, Polygon

from rescene_core.assembly.objects import footprint
from rescene_core.assembly.room import Wall
from rescene_core.assembly.state import LayoutState
from rescene_core.assembly.transforms import horizontal, level_correction, nearest_axis, signed_yaw
from rescene_core.geometry.sim3 import apply, inverse, scale_of
from rescene_core.records import InstanceId

FACE_YAW_BIN_DEG = 2.0
"""Bin width (deg) of the face-direction histogram."""
FACE_YAW_MIN_FRACTION = 0.08
"""Smallest share of the vertical face area a face direction needs to set the yaw."""
SEEN_SIDE_TOLERANCE = 0.10
"""How far (m) a generated asset's bounding-box centre may lie behind a wall or outside the floor polygon
and still count as inside: a single-view completion is mirrored about the seen points, so the centre lies
near the seen surface, which is inside the room up to depth noise and registration error (about 0.1 m on the standard preset)."""
VERTICAL_FACE_MAX_TILT_DEG = 30.0
"""Faces whose normal is within this angle of horizontal count as vertical faces (deg)."""


def trusts_full_extent(state: LayoutState, i: InstanceId) -> bool:
    return bool(state.objects[i].exact_shape)


def wall_gap(state: LayoutState, i: InstanceId, wall: Wall) -> float:
    """Gap (m) between object i and ``wall`` (negative: penetration), read as described above."""
    gap = float(wall.distance(state.vertices(i)).min())
    if gap >= 0.0 or not centre_inside_wall(wall, state.centre(i)):
        return gap
    registered = -float(wall.distance(state.objects[i].world_vertices()).min())
    return 0.0 if completion_crossing(state, i, -gap, registered) else gap


def completion_crossing(state: LayoutState, i: InstanceId, depth: float, registered_depth: float) -> bool:
    """Whether a crossing ``depth`` m deep (of a wall or the floor polygon) by object i is read as a
    completion error: generated assets only, deeper than ``completion_min_excess`` both now and at the
    registered pose (``registered_depth``, the same boundary): the evidence is the asset as registered,
    so a crossing the solver's own moves made (a depenetration push) is always repaired."""
    excess = state.config.completion_min_excess
    if excess is None:
        return False
    return not trusts_full_extent(state, i) and depth > excess and registered_depth > excess


def polygon_excursion(polygon: Polygon, fp: Polygon) -> float:
    """How far (m) the footprint ``fp`` reaches beyond ``polygon`` (0 when inside)."""
    pts = shapely.points(np.asarray(fp.exterior.coords))
    return float(shapely.distance(polygon, pts).max())


def centre_inside_wall(wall: Wall, centre: NDArray) -> bool:
    """Whether a generated asset's centre [3] counts as in front of ``wall`` (see SEEN_SIDE_TOLERANCE)."""
    return float(wall.distance(np.asarray(centre)[None])[0]) > -SEEN_SIDE_TOLERANCE


def centre_inside_polygon(polygon: Polygon, centre: NDArray) -> bool:
    """Whether a generated asset's centre [3] counts as inside the floor ``polygon``."""
    return bool(polygon.buffer(SEEN_SIDE_TOLERANCE).contains(Point(centre[0], centre[1])))


def containment_footprint(state: LayoutState, i: InstanceId) -> Polygon:
    """Footprint of object i used by the containment tests and repairs (see the module docstring)."""
    fp = state.footprint(i)
    poly = state.room.polygon
    if poly is None or trusts_full_extent(state, i) or fp.within(poly):
        return fp
    registered = polygon_excursion(poly, footprint(state.objects[i].world_vertices()))
    if not completion_crossing(state, i, polygon_excursion(poly, fp), registered):
        return fp
    if not centre_inside_polygon(poly, state.centre(i)):
        return fp
    core = fp.intersection(poly.buffer(-state.config.wall_collision_margin, join_style="mitre"))
    if core.is_empty or core.area <= 0:
        return fp
    hull = core.convex_hull
    return hull if isinstance(hull, Polygon) else fp


def face_yaw(
    state: LayoutState, i: InstanceId, direction: NDArray, max_yaw_rad: float, pose: NDArray | None = None
) -> float | None:
    """Signed yaw (rad, about the room's up) turning object i's nearest vertical face direction onto
    ``direction`` (either sense), within ``max_yaw_rad``; None when no face direction is strong enough.
    ``pose``: world_from_asset [4, 4] to read the faces at (default: its current pose)."""
    up = state.room.up
    obj = state.objects[i]
    verts = state.vertices(i) if pose is None else obj.world_vertices(pose)
    tri = verts[np.asarray(obj.faces)]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(normals, axis=1)
    ok = area > 1e-12
    n = normals[ok] / (2.0 * area[ok, None])
    area = area[ok]
    vertical = np.abs(n @ up) < np.sin(np.radians(VERTICAL_FACE_MAX_TILT_DEG))
    if not vertical.any():
        return None
    n, area = n[vertical], area[vertical]
    d = horizontal(np.asarray(direction, dtype=np.float64), up)
    d = d / np.linalg.norm(d)
    side = np.cross(up, d)
    # angle of each face normal from the direction, folded to [-90, 90) deg (a face and its opposite agree)
    ang = np.arctan2(n @ side, n @ d)
    ang = (ang + np.pi / 2) % np.pi - np.pi / 2
    width = np.radians(FACE_YAW_BIN_DEG)
    edges = np.arange(-max_yaw_rad - width, max_yaw_rad + 2 * width, width)
    hist, _ = np.histogram(ang, bins=edges, weights=area)
    hist = np.convolve(hist, [0.25, 0.5, 0.25], mode="same")
    k = int(np.argmax(hist))
    if hist[k] < FACE_YAW_MIN_FRACTION * area.sum():
        return None
    centre = 0.5 * (edges[k] + edges[k + 1])
    near = np.abs(ang - centre) <= 1.5 * width
    peak = float(np.average(ang[near], weights=area[near])) if near.any() else centre
    if abs(peak) > max_yaw_rad:
        return None
    return -peak  # turning by -peak brings that face direction onto ``direction``


def yaw_to_direction(state: LayoutState, i: InstanceId, direction: NDArray, candidates, max_yaw_rad: float):
    """(yaw in rad turning object i square to ``direction``, asset axis index, sign) or None when no yaw
    within ``max_yaw_rad`` is supported. Exact shapes: the nearest asset axis; generated ones: face_yaw
    (axis -1: no asset axis is used)."""
    pose = state.pose(i)
    if trusts_full_extent(state, i):
        idx, sign, axis = nearest_axis(pose, direction, candidates)
        return signed_yaw(axis, direction, state.room.up), idx, sign
    yaw = face_yaw(state, i, direction, max_yaw_rad)
    if yaw is None:
        return None
    return yaw, -1, 1.0


POINTS_FIT_MARGIN = 0.03
"""Observed points within this distance (m) of an object's mesh bounding box (in the asset frame, scaled to
metres) count as explained by the mesh at that pose."""
POINTS_FIT_MAX_DROP = 0.5
"""A relation's correction of a generated asset may lower the share of its observed points its mesh box
explains by at most this much (absolute) below the share at the registered pose; a larger drop moves the
object away from where the capture saw it (a table top registered where it was seen, whose mesh lacks the
legs, dropped 0.7 m onto the floor), so the correction is refused and the object keeps its registered pose."""


def _box_frame(obj, world_from_asset: NDArray):
    """``obj.points`` in its asset frame at ``world_from_asset`` [4, 4] with the mesh box's corners and the
    pose's scale: (local [n, 3], lo [3], hi [3], scale), or None without points."""
    pts = obj.points
    if pts is None or len(pts) == 0:
        return None
    pose = np.asarray(world_from_asset, dtype=np.float64)
    local = apply(inverse(pose), np.asarray(pts, dtype=np.float64))
    return local, obj.vertices.min(axis=0), obj.vertices.max(axis=0), scale_of(pose)


def points_fit(obj, world_from_asset: NDArray) -> float | None:
    """Share of ``obj.points`` lying within POINTS_FIT_MARGIN of the mesh's bounding box at
    ``world_from_asset`` [4, 4]; None without points."""
    frame = _box_frame(obj, world_from_asset)
    if frame is None:
        return None
    local, lo, hi, scale = frame
    outside = np.maximum(np.maximum(lo - local, local - hi), 0.0)
    return float(np.mean(np.linalg.norm(outside, axis=1) * scale <= POINTS_FIT_MARGIN))


def surface_fit(obj, world_from_asset: NDArray) -> float | None:
    """Share of ``obj.points`` within POINTS_FIT_MARGIN of the surface of the mesh's bounding box at
    ``world_from_asset`` [4, 4], inside or outside; None without points. Unlike ``points_fit`` it drops when
    a move buries the seen surface inside the box as well as when it leaves it outside (a push towards the
    camera that saw the object)."""
    frame = _box_frame(obj, world_from_asset)
    if frame is None:
        return None
    local, lo, hi, scale = frame
    outside = np.linalg.norm(np.maximum(np.maximum(lo - local, local - hi), 0.0), axis=1)
    inside = np.minimum(local - lo, hi - local).min(axis=1)  # depth below the nearest face (< 0: outside)
    depth = np.where(inside > 0.0, inside, outside)
    return float(np.mean(depth * scale <= POINTS_FIT_MARGIN))


def evidence_refuses(state: LayoutState, i: InstanceId, new_pose: NDArray) -> str | None:
    """Why moving generated object i to ``new_pose`` contradicts its observed points (None: it does not)."""
    obj = state.objects[i]
    if obj.exact_shape or obj.points is None:
        return None
    before = points_fit(obj, obj.world_from_asset)
    after = points_fit(obj, new_pose)
    if before is None or after is None or after >= before - POINTS_FIT_MAX_DROP:
        return None
    return (
        f"the correction would leave {1 - after:.0%} of the object's observed points outside its mesh "
        f"(registered: {1 - before:.0%}); the mesh lacks part of the object, so it keeps its registered pose"
    )


SEEN_BOX_MARGIN = 0.05
"""Observed points farther than this (m) outside an object's registered mesh box are another object's
(segmentation bleed), not evidence of where it stands."""
SNAP_MAX_LEFT_BEHIND = 0.3
"""A wall or corner snap of a generated asset may leave at most this share of the points its registered mesh
box held (within POINTS_FIT_MARGIN) outside the box: a larger share means the mesh is thinner than the
object (a bookshelf generated as a slab of its front), and pushing the slab to the wall moves it away from
the front the capture saw."""


def points_in_box(obj) -> NDArray[np.float64]:
    """``obj``'s observed points [k, 3] (world) within SEEN_BOX_MARGIN of its mesh box at its registered
    pose: farther ones are another object's (segmentation bleed)."""
    pts = np.asarray(obj.points, dtype=np.float64)
    local = apply(inverse(obj.world_from_asset), pts)
    margin = SEEN_BOX_MARGIN / scale_of(obj.world_from_asset)
    lo, hi = obj.vertices.min(axis=0) - margin, obj.vertices.max(axis=0) + margin
    return pts[np.all((local >= lo) & (local <= hi), axis=1)]


def snap_refuses(state: LayoutState, i: InstanceId, new_pose: NDArray) -> str | None:
    """Why a wall or corner snap of generated object i to ``new_pose`` [4, 4] leaves its observed points
    behind (SNAP_MAX_LEFT_BEHIND), or None. Only the points near its registered mesh box count, so stray
    points of other objects neither refuse nor allow a snap."""
    obj = state.objects[i]
    if obj.exact_shape or obj.points is None or len(obj.points) == 0:
        return None
    seen = points_in_box(obj)
    if len(seen) == 0:
        return None
    held_now = _held(obj, state.pose(i), seen)
    held_after = _held(obj, new_pose, seen)
    if held_now - held_after <= SNAP_MAX_LEFT_BEHIND:
        return None
    return (
        f"the snap would leave {held_now - held_after:.0%} of the points its mesh box holds outside it (the "
        "mesh is thinner than the object the capture saw); it keeps its place"
    )


def _held(obj, world_from_asset: NDArray, points: NDArray) -> float:
    """Share of world ``points`` [n, 3] within POINTS_FIT_MARGIN of ``obj``'s mesh box at ``world_from_asset``."""
    local = apply(inverse(world_from_asset), points)
    margin = POINTS_FIT_MARGIN / scale_of(world_from_asset)
    lo, hi = obj.vertices.min(axis=0) - margin, obj.vertices.max(axis=0) + margin
    return float(np.mean(np.all((local >= lo) & (local <= hi), axis=1)))


LEVEL_PIVOT_MIN_POINTS = 12
"""Fewest observed points in its registered mesh box a generated asset needs for them to fix the point it
is levelled about (``level_pivot``); with fewer, the centre of its bounding box."""


def level_pivot(state: LayoutState, i: InstanceId) -> NDArray[np.float64]:
    """World point [3] (m) about which object i is levelled at its current pose.

    For a generated asset with observed points: their per-axis median (the points within SEEN_BOX_MARGIN of
    its registered mesh box, ``points_in_box``, carried to its current pose). The part the capture saw stays
    where it was seen and the unseen completion swings about it; about its bounding-box centre, levelling a
    mesh registered 7-11 deg tilted slides the seen part sideways and, as the box of the tilted mesh is not
    the box of the levelled one, the box centre with it. Otherwise (an exact shape, too few points) the
    centre of its current bounding box."""
    obj = state.objects[i]
    if not obj.exact_shape and obj.points is not None and len(obj.points) >= LEVEL_PIVOT_MIN_POINTS:
        seen = points_in_box(obj)
        if len(seen) >= LEVEL_PIVOT_MIN_POINTS:
            now = apply(state.pose(i) @ inverse(obj.world_from_asset), np.median(seen, axis=0)[None])[0]
            return np.asarray(now, dtype=np.float64)
    return state.centre(i)


def levelling(
    state: LayoutState, i: InstanceId, pose: NDArray[np.float64], pivot: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    """Rotation [4, 4] levelling object i at ``pose`` about ``pivot`` (world [3], ``level_pivot``), and the
    tilt it removes (rad).

    A generated asset's frame is z-up (both backends, and the registration's rotation gate measures the tilt
    of that axis), so its +z is turned onto the floor normal whatever the tilt: registration passes a pose up
    to its result gate (50 deg), and a table lamp registered 49 deg over, left tilted past the 45 deg an exact
    shape's limit allows, fell off its desk. An exact shape's frame is the object's own (a box may lie on its
    side on purpose): its axis nearest the floor normal is levelled when tilted at most
    ``max_level_tilt_deg``."""
    obj, up = state.objects[i], state.room.up
    if obj.exact_shape:
        return level_correction(pose, up, pivot, np.radians(state.config.max_level_tilt_deg))
    return level_correction(pose, up, pivot, np.pi, candidates=(2,))


LEVEL_REFIT_MIN_TILT_DEG = 10.0
"""A generated asset levelled by more than this (deg) has its horizontal position fitted again to its observed
points (``refit_horizontal``): the levelled mesh is not the registered one, and neither the point it was
levelled about nor its registered box centre says where the levelled mesh's surface meets the points."""
LEVEL_REFIT_MAX_SHIFT = 0.04
"""Largest horizontal step (m) of that fit: it corrects where the levelled surface sits on the seen one, not
where the object stands."""
LEVEL_REFIT_MAX_PAIR = 0.05
"""Observed points farther than this (m) from the levelled mesh's surface take no part in the fit (another
object's points, or a part the generated mesh lacks)."""
LEVEL_REFIT_ITERATIONS = 10
"""Nearest-point iterations of the fit."""
LEVEL_REFIT_SAMPLES = 4000
"""Points sampled on the mesh's surface (area-weighted, fixed seed) that the observed points are paired with."""
LEVEL_REFIT_MIN_GAIN = 0.001
"""Smallest drop (m) of the points' mean distance to the surface (each capped at LEVEL_REFIT_MAX_PAIR) for the
fitted step to be taken."""


def refit_horizontal(state: LayoutState, i: InstanceId, pose: NDArray) -> NDArray[np.float64] | None:
    """Horizontal step [3] (m, perpendicular to the room's up) moving generated object i at ``pose``
    (world_from_asset [4, 4], after levelling and the rule's vertical placement) so that its mesh surface
    best explains its observed points, or None (an exact shape, fewer than LEVEL_PIVOT_MIN_POINTS points in
    its registered box, or no step lowering their mean distance to the surface by LEVEL_REFIT_MIN_GAIN).

    Point-to-plane nearest-point iterations (a KD-tree over LEVEL_REFIT_SAMPLES points sampled on the
    mesh's surface, each with its face's normal) restricted to the two horizontal directions, so the height the rule chose stays; pairs
    farther than LEVEL_REFIT_MAX_PAIR are left out and the step is bounded by LEVEL_REFIT_MAX_SHIFT. The
    points are those within SEEN_BOX_MARGIN of the registered mesh box (``points_in_box``), where the
    capture saw them."""
    obj = state.objects[i]
    if obj.exact_shape or obj.points is None or len(obj.points) < LEVEL_PIVOT_MIN_POINTS:
        return None
    seen = points_in_box(obj)
    if len(seen) < LEVEL_PIVOT_MIN_POINTS:
        return None
    mesh = obj.mesh()
    pose = np.asarray(pose, dtype=np.float64)
    samples, face = trimesh.sample.sample_surface(mesh, LEVEL_REFIT_SAMPLES, seed=0)
    centres = apply(pose, np.asarray(samples, dtype=np.float64))
    normals = np.asarray(mesh.face_normals, dtype=np.float64)[face] @ pose[:3, :3].T
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    tree = cKDTree(centres)
    up = state.room.up
    e1 = horizontal(np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0]), up)
    e1 /= np.linalg.norm(e1)
    basis = np.stack([e1, np.cross(up, e1)], axis=1)  # [3, 2]

    def pairs(step: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """(distance [n], plane residual [n], pair normals [n, 3]) of the points against the mesh moved by step."""
        dist, k = tree.query(seen - step)
        residual = np.einsum("ij,ij->i", seen - step - centres[k], normals[k])
        return dist, residual, normals[k]

    def score(step: NDArray) -> float:
        dist, residual, _ = pairs(step)
        return float(np.mean(np.minimum(np.minimum(dist, np.abs(residual) + 1e-3), LEVEL_REFIT_MAX_PAIR)))

    step = np.zeros(3)
    for _ in range(LEVEL_REFIT_ITERATIONS):
        dist, residual, n = pairs(step)
        near = dist <= LEVEL_REFIT_MAX_PAIR
        if near.sum() < LEVEL_PIVOT_MIN_POINTS:
            break
        a = n[near] @ basis  # [m, 2]: how a horizontal move of the mesh changes each residual (with a minus)
        # ridge term: a direction no vertical face constrains (points only on a top) is not moved along
        gram = a.T @ a + 1e-3 * len(a) * np.eye(2)
        delta = np.linalg.solve(gram, a.T @ residual[near])
        step = step + basis @ delta
        length = float(np.linalg.norm(step))
        if length > LEVEL_REFIT_MAX_SHIFT:
            step *= LEVEL_REFIT_MAX_SHIFT / length
        if float(np.linalg.norm(delta)) < 1e-4:
            break
    if score(np.zeros(3)) - score(step) < LEVEL_REFIT_MIN_GAIN:
        return None
    return step


def levelled_refit(state: LayoutState, i: InstanceId, pose: NDArray) -> NDArray[np.float64] | None:
    """``refit_horizontal`` of generated object i at ``pose`` when levelling removes more than
    LEVEL_REFIT_MIN_TILT_DEG from its registered pose (the floor and support rules); None otherwise."""
    if state.objects[i].exact_shape or registered_tilt_deg(state, i) <= LEVEL_REFIT_MIN_TILT_DEG:
        return None
    return refit_horizontal(state, i, pose)


def registered_tilt_deg(state: LayoutState, i: InstanceId) -> float:
    """Tilt (deg) levelling removes from object i at its registered pose (0 when it is not levelled): a rule
    that seats an object already levelled by an earlier stage (a re-seat) still knows it was levelled."""
    obj = state.objects[i]
    return float(np.degrees(levelling(state, i, obj.world_from_asset, obj.world_vertices().mean(axis=0))[1]))
