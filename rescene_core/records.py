"""Typed records handed between the stages of the pipeline.

Every record is a frozen dataclass. Array fields say their dtype, shape, units and frame in the
docstring; conventions follow DESIGN.md: metres, world z up, OpenCV cameras (x right, y down,
z forward), and ``a_from_b`` transforms that map frame-b points into frame a.

Records that go to disk have ``to_json`` / ``from_json`` with plain JSON types only (no pickles).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any, NewType

import numpy as np
from numpy.typing import NDArray

InstanceId = NewType("InstanceId", int)
"""Canonical instance id taken from the capture's panoptic output (> 0; 0 means 'no instance')."""


class Relation(enum.StrEnum):
    """Relation of a child to its parent in the scene graph."""

    RESTS_ON = "rests-on"
    MOUNTS_ON = "mounts-on"


class Root(enum.StrEnum):
    """Structural roots of the scene graph. Which wall is meant is resolved later, geometrically."""

    FLOOR = "floor"
    WALL = "wall"


class Stage(enum.StrEnum):
    """The stages of the pipeline, by the one name used everywhere: task names, run-log segments,
    ``Missing.stage``, manifest stage counts, fault injection and the library's ``STAGE`` constants.

    Earlier names are accepted when reading (``"hierview"`` is ``VIEW``, ``"assembly"`` is ``ATTACHMENT``).
    """

    VALIDATE = "validate"
    SHELL = "shell"
    VIEW = "view"
    KEYFRAMES = "keyframes"
    ASSET = "asset"
    REGISTRATION = "registration"
    RELATIONS = "relations"
    FUSION = "fusion"
    SNAPSHOT = "snapshot"
    ATTACHMENT = "attachment"
    EXPORT = "export"
    SIMCHECK = "simcheck"
    EVALUATION = "evaluation"

    @classmethod
    def _missing_(cls, value: object) -> Stage | None:
        return _STAGE_ALIASES.get(str(value))


_STAGE_ALIASES = {"hierview": Stage.VIEW, "assembly": Stage.ATTACHMENT}


Parent = InstanceId | Root
"""A parent is another instance or a structural root."""

STRUCTURAL_LABELS = frozenset({"floor", "wall", "ceiling"})


def parent_to_json(parent: Parent) -> int | str:
    return parent.value if isinstance(parent, Root) else int(parent)


def _same_parent(a: Parent, b: Parent) -> bool:
    """Whether two parents are the same root, or the same instance."""
    if isinstance(a, Root) or isinstance(b, Root):
        return a is b
    return int(a) == int(b)


def parent_from_json(value: int | str) -> Parent:
    if isinstance(value, str):
        try:
            return Root(value)
        except ValueError:
            if value.isdigit():
                return InstanceId(int(value))
            raise
    return InstanceId(int(value))


@dataclass(frozen=True)
class Camera:
    """A calibrated pinhole camera of one frame.

    K: float64 [3, 3] intrinsics in pixels (fx, fy, cx, cy; zero skew).
    world_from_cam: float64 [4, 4] rigid pose, OpenCV camera axes, metres.
    width, height: image size in pixels.
    """

    K: NDArray[np.float64]
    world_from_cam: NDArray[np.float64]
    width: int
    height: int

    @property
    def cam_from_world(self) -> NDArray[np.float64]:
        rot = self.world_from_cam[:3, :3]
        out = np.eye(4)
        out[:3, :3] = rot.T
        out[:3, 3] = -rot.T @ self.world_from_cam[:3, 3]
        return out

    @property
    def center(self) -> NDArray[np.float64]:
        """Camera centre in the world frame, float64 [3], metres."""
        return self.world_from_cam[:3, 3]

    def project(self, points_world: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Project world points [n, 3] -> (pixel coordinates [n, 2] (u right, v down), depth along z [n])."""
        cam_from_world = self.cam_from_world
        pts = np.asarray(points_world, dtype=np.float64) @ cam_from_world[:3, :3].T + cam_from_world[:3, 3]
        z = pts[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = (pts[:, :2] / z[:, None]) * np.diag(self.K)[:2] + self.K[:2, 2]
        return uv, z


@dataclass(frozen=True)
class Instance:
    """One panoptic instance: canonical id, category label, and whether it is structure (floor/wall/ceiling)."""

    id: InstanceId
    label: str
    structural: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"id": int(self.id), "label": self.label, "structural": bool(self.structural)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Instance:
        return cls(InstanceId(int(d["id"])), str(d["label"]), bool(d.get("structural", False)))


@dataclass(frozen=True)
class InstancePoints:
    """The semantic point cloud P_i of one instance.

    points: float32 [n, 3], world frame, metres.
    colors: uint8 [n, 3], RGB.
    """

    instance: InstanceId
    points: NDArray[np.float32]
    colors: NDArray[np.uint8]

    def __len__(self) -> int:
        return int(self.points.shape[0])


@dataclass(frozen=True)
class Plane:
    """Plane ``normal . x + offset = 0`` in the world frame; unit normal [3] points into the room."""

    normal: tuple[float, float, float]
    offset: float

    def signed_distance(self, points: NDArray) -> NDArray[np.float64]:
        """Signed distance (m) of points [n, 3] from the plane, positive on the room side."""
        return np.asarray(points, dtype=np.float64) @ np.asarray(self.normal) + self.offset

    def to_json(self) -> dict[str, Any]:
        return {"normal": [float(v) for v in self.normal], "offset": float(self.offset)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Plane:
        n = d["normal"]
        return cls((float(n[0]), float(n[1]), float(n[2])), float(d["offset"]))


@dataclass(frozen=True)
class WallPlane:
    """A vertical wall: its plane (normal into the room, horizontal) and its extent along the wall.

    segment: the wall's footprint on the floor, ((x0, y0), (x1, y1)) in metres, world frame.
    """

    id: int
    plane: Plane
    segment: tuple[tuple[float, float], tuple[float, float]]

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "plane": self.plane.to_json(), "segment": [list(p) for p in self.segment]}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> WallPlane:
        (x0, y0), (x1, y1) = d["segment"]
        return cls(int(d["id"]), Plane.from_json(d["plane"]), ((float(x0), float(y0)), (float(x1), float(y1))))


SHELL_VERSION = 2
"""Version of the ``shell.json`` format: 2 adds ``edge_walls`` and ``seen_floor_polygon`` (version 1, read
back without them, bounds every edge of its floor polygon by a wall)."""


@dataclass(frozen=True)
class RoomShell:
    """The room's structure: floor plane, vertical walls, and the floor polygon.

    floor_polygon: counter-clockwise (x, y) vertices in metres, world frame, without repeating the first: the
        floor's extent (the floor seen, the footprints of the objects standing over it and the cameras' own
        positions, none of it behind an observed wall).
    ceiling_height: height of the ceiling above the floor plane (m), when known.
    edge_walls: per edge k of floor_polygon (vertex k to vertex k + 1), the id of the observed wall it lies
        on, or None where no wall was observed (an open side: the floor may go on beyond it). None (a shell
        without the record, e.g. version 1): every edge is bounded by a wall.
    seen_floor_polygon: the part of the floor the capture saw (same convention), when recorded.
    """

    floor: Plane
    walls: tuple[WallPlane, ...]
    floor_polygon: tuple[tuple[float, float], ...]
    ceiling_height: float | None = None
    edge_walls: tuple[int | None, ...] | None = None
    seen_floor_polygon: tuple[tuple[float, float], ...] | None = None

    def polygon(self):
        """The floor polygon as a shapely Polygon."""
        from shapely.geometry import Polygon

        return Polygon(self.floor_polygon)

    def open_edges(self) -> tuple[int, ...]:
        """Indices of the floor polygon's edges with no observed wall (none when ``edge_walls`` is None)."""
        if self.edge_walls is None:
            return ()
        return tuple(k for k, w in enumerate(self.edge_walls) if w is None)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "version": SHELL_VERSION,
            "floor": self.floor.to_json(),
            "walls": [w.to_json() for w in self.walls],
            "floor_polygon": [list(p) for p in self.floor_polygon],
            "ceiling_height": self.ceiling_height,
            "edge_walls": None if self.edge_walls is None else list(self.edge_walls),
            "seen_floor_polygon": None
            if self.seen_floor_polygon is None
            else [list(p) for p in self.seen_floor_polygon],
        }
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> RoomShell:
        polygon = tuple((float(x), float(y)) for x, y in d["floor_polygon"])
        edge_walls = d.get("edge_walls")
        if edge_walls is not None and len(edge_walls) != len(polygon):
            raise ValueError(
                f"shell: edge_walls has {len(edge_walls)} entries for {len(polygon)} floor polygon edges; "
                "re-estimate the shell"
            )
        seen = d.get("seen_floor_polygon")
        return cls(
            floor=Plane.from_json(d["floor"]),
            walls=tuple(WallPlane.from_json(w) for w in d["walls"]),
            floor_polygon=polygon,
            ceiling_height=None if d.get("ceiling_height") is None else float(d["ceiling_height"]),
            edge_walls=None if edge_walls is None else tuple(None if w is None else int(w) for w in edge_walls),
            seen_floor_polygon=None if seen is None else tuple((float(x), float(y)) for x, y in seen),
        )


@dataclass(frozen=True)
class ViewChoice:
    """The view HierView (or a baseline) chose for one instance.

    frame: chosen frame index t*. method: the selection method. reason: why this frame.
    candidates: one row per candidate frame with every score computed ({"frame", "area", "bbox_ratio",
    "semantic", "completeness", "stage_reached", ...}).
    """

    instance: InstanceId
    frame: int
    method: str
    reason: str
    candidates: tuple[dict[str, Any], ...] = ()
    semantic_backend: str = "none"

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "frame": int(self.frame),
            "method": self.method,
            "reason": self.reason,
            "semantic_backend": self.semantic_backend,
            "candidates": list(self.candidates),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> ViewChoice:
        return cls(
            InstanceId(int(d["instance"])),
            int(d["frame"]),
            str(d["method"]),
            str(d["reason"]),
            tuple(d.get("candidates", ())),
            str(d.get("semantic_backend", "none")),
        )


@dataclass(frozen=True)
class Asset:
    """A generated mesh in the asset's own normalised frame.

    vertices: float64 [v, 3] in the asset frame (unit bounding box, centred). faces: int64 [f, 3].
    backend: which generator produced it ('lift', 'sam3d', 'gt'). metadata: backend details.
    asset_from_generator: float64 [4, 4] Sim(3) from the generator's raw output frame to the asset frame.
    """

    instance: InstanceId
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    backend: str
    metadata: dict[str, Any] = field(default_factory=dict)
    asset_from_generator: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))


@dataclass(frozen=True)
class Pose:
    """The registered pose T_i of one instance's asset.

    world_from_asset: float64 [4, 4] Sim(3) mapping asset-frame points to world metres.
    method: which solver produced it. diagnostics: residuals, inlier ratios and every gate decision.
    """

    instance: InstanceId
    world_from_asset: NDArray[np.float64]
    method: str
    diagnostics: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "world_from_asset": np.asarray(self.world_from_asset).tolist(),
            "method": self.method,
            "diagnostics": self.diagnostics,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Pose:
        return cls(
            InstanceId(int(d["instance"])),
            np.asarray(d["world_from_asset"], dtype=np.float64),
            str(d["method"]),
            dict(d.get("diagnostics", {})),
        )


@dataclass(frozen=True)
class Edge:
    """Scene-graph edge into ``child``: (c_k, r_k, p_k, omega_k).

    confidence: omega in [0, 1]. scores: fusion terms (V, G, Phi, shell, S). flags: e.g. 'uncertain'.
    wall_id: the concrete wall a 'mounts-on wall' edge was resolved to, when known.
    """

    child: InstanceId
    relation: Relation
    parent: Parent
    confidence: float = 1.0
    scores: dict[str, float] = field(default_factory=dict)
    flags: tuple[str, ...] = ()
    wall_id: int | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "child": int(self.child),
            "relation": self.relation.value,
            "parent": parent_to_json(self.parent),
            "confidence": float(self.confidence),
            "scores": {k: float(v) for k, v in self.scores.items()},
            "flags": list(self.flags),
            "wall_id": self.wall_id,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Edge:
        return cls(
            child=InstanceId(int(d["child"])),
            relation=Relation(d["relation"]),
            parent=parent_from_json(d["parent"]),
            confidence=float(d.get("confidence", 1.0)),
            scores={k: float(v) for k, v in d.get("scores", {}).items()},
            flags=tuple(d.get("flags", ())),
            wall_id=None if d.get("wall_id") is None else int(d["wall_id"]),
        )


@dataclass(frozen=True)
class SceneGraph:
    """A forest over instances rooted at floor/wall: at most one incoming edge per child."""

    edges: tuple[Edge, ...]

    def parent_of(self) -> dict[InstanceId, Edge]:
        return {e.child: e for e in self.edges}

    def children(self, parent: Parent, relation: Relation | None = None) -> list[InstanceId]:
        """The children of ``parent`` (an instance or a root), sorted by id; only those attached by
        ``relation`` when it is given."""
        return sorted(
            e.child
            for e in self.edges
            if (relation is None or e.relation == relation) and _same_parent(e.parent, parent)
        )

    def descendants(self, instance: InstanceId, relation: Relation | None = None) -> list[InstanceId]:
        """Its children, then theirs (breadth first, each once; a cycle back to ``instance`` stops there)."""
        out: list[InstanceId] = []
        todo = self.children(instance, relation)
        while todo:
            c = todo.pop(0)
            if c not in out and c != instance:
                out.append(c)
                todo += self.children(c, relation)
        return out

    def object_parents(self, relation: Relation | None = None) -> dict[InstanceId, InstanceId]:
        """Child -> the object it is attached to (edges to another object, not to the floor or a wall)."""
        return {
            e.child: InstanceId(int(e.parent))
            for e in self.edges
            if (relation is None or e.relation == relation) and not isinstance(e.parent, Root)
        }

    def check(self) -> list[str]:
        """Reasons the graph is not a valid forest (duplicate children, self loops, cycles, dangling parents)."""
        problems: list[str] = []
        by_child: dict[InstanceId, Edge] = {}
        for e in self.edges:
            if e.child in by_child:
                problems.append(f"instance {e.child} has more than one parent")
            by_child[e.child] = e
            if not isinstance(e.parent, Root) and e.parent == e.child:
                problems.append(f"instance {e.child} is its own parent")
        for e in self.edges:
            if not isinstance(e.parent, Root) and e.parent not in by_child:
                problems.append(f"instance {e.child} has parent {e.parent}, which has no edge to a root")
        for start in by_child:
            seen = {start}
            node: Parent = by_child[start].parent
            while not isinstance(node, Root) and node in by_child:
                if node in seen:
                    problems.append(f"cycle through instance {start}")
                    break
                seen.add(node)
                node = by_child[node].parent
        return problems

    def to_json(self) -> dict[str, Any]:
        return {"edges": [e.to_json() for e in self.edges]}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SceneGraph:
        return cls(tuple(Edge.from_json(e) for e in d["edges"]))


@dataclass(frozen=True)
class Missing:
    """An instance a stage could not handle: later stages skip it, and the report lists it.

    stage: a ``Stage`` (a plain stage name such as ``"registration"`` is converted on construction).
    """

    instance: InstanceId
    stage: Stage
    reason: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "stage", Stage(self.stage))

    def to_json(self) -> dict[str, Any]:
        return {"instance": int(self.instance), "stage": self.stage.value, "reason": self.reason}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Missing:
        return cls(InstanceId(int(d["instance"])), Stage(d["stage"]), str(d["reason"]))


class CompletionKind(enum.StrEnum):
    """What a ``Completion`` adds to an object's mesh."""

    SUPPORT_PLANE = "support plane"
    """A horizontal polygon [k, 3] a child stands on (a shelf board the generated mesh lacks)."""
    BASE = "base"
    """The vertices [k, 3] of a convex solid between the floor and the mesh's lowest part (a leg, a plinth
    the generated mesh lacks)."""
    CUT = "cut"
    """A plane [2, 3] (a point on it and that point plus the normal, asset frame) the mesh is cut at,
    keeping the side the normal points to: a completion reaching through the floor or a wall the capture
    saw, where none of the object's points are."""


@dataclass(frozen=True)
class Completion:
    """Geometry an object's generated mesh lacks, added by attachment from the object's observed points (or
    from its relation when the points show nothing), so that contacts and colliders agree on it.

    points_asset: float64 [k, 3], asset frame (apply the object's world_from_asset to place it): the
      polygon of a support plane, the vertices of a base (its convex hull is the solid), or a cut plane's
      point and that point plus its normal.
    source: what showed the geometry (a sentence for the layout and the export report).
    """

    instance: InstanceId
    kind: CompletionKind
    points_asset: NDArray[np.float64]
    source: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "kind": self.kind.value,
            "points_asset": np.asarray(self.points_asset, np.float64).tolist(),
            "source": self.source,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Completion:
        return cls(
            InstanceId(int(d["instance"])),
            CompletionKind(d["kind"]),
            np.asarray(d["points_asset"], np.float64).reshape(-1, 3),
            str(d.get("source", "")),
        )


@dataclass(frozen=True)
class Layout:
    """The attachment-optimised layout: final poses and the operations that produced them.

    world_from_asset: per instance, float64 [4, 4] Sim(3), T_hat_i = Delta T_i * T_i.
    operations: one record per operation applied ({"instance", "rule", "transform", ...}).
    """

    world_from_asset: dict[InstanceId, NDArray[np.float64]]
    operations: tuple[dict[str, Any], ...] = ()
    missing: tuple[Missing, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "objects": {str(int(k)): np.asarray(v).tolist() for k, v in self.world_from_asset.items()},
            "operations": list(self.operations),
            "missing": [m.to_json() for m in self.missing],
        }

    def completions(self) -> dict[InstanceId, list[Completion]]:
        """Per instance, the geometry attachment added to its mesh (the ``support plane`` and ``base``
        operations, in the order applied)."""
        out: dict[InstanceId, list[Completion]] = {}
        for op in self.operations:
            completion = completion_of_operation(op)
            if completion is not None:
                out.setdefault(completion.instance, []).append(completion)
        return out

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Layout:
        return cls(
            {InstanceId(int(k)): np.asarray(v, dtype=np.float64) for k, v in d["objects"].items()},
            tuple(d.get("operations", ())),
            tuple(Missing.from_json(m) for m in d.get("missing", ())),
        )


def completion_of_operation(op: dict[str, Any]) -> Completion | None:
    """The Completion a layout operation records (rule ``support plane``: ``polygon_asset``; rules ``base``
    and ``cut``: ``points_asset``), or None for any other operation."""
    rule = op.get("rule")
    if rule == CompletionKind.SUPPORT_PLANE.value:
        points = op["polygon_asset"]
    elif rule in (CompletionKind.BASE.value, CompletionKind.CUT.value):
        points = op["points_asset"]
    else:
        return None
    return Completion(
        InstanceId(int(op["instance"])),
        CompletionKind(rule),
        np.asarray(points, np.float64).reshape(-1, 3),
        str(op.get("source", "")),
    )


class RefStatus(enum.StrEnum):
    """Whether a stage produced its output for the item (``OK``) or an explicit Missing (``MISSING``)."""

    OK = "ok"
    MISSING = "missing"


@dataclass(frozen=True)
class Ref:
    """What a pipeline task returns: a small reference to the file it wrote, never the data itself.

    kind: what the file holds ("shell", "view", "asset", "pose", "graph", "layout", "scene", ...).
    path: the file, relative to the run directory (absolute for the capture, which lives outside it).
    sha256: content hash of that file (of the whole Zarr store for the capture).
    item: the instance id or key-frame index, None for scene-level outputs.
    status: OK, or MISSING when the stage recorded ``missing`` instead of an output.
    numbers: a few plain JSON numbers for tables and logs (faces, frame, rmse, ...).
    detail: small JSON values a later stage needs (the key-frame list, the export's file hashes).

    Only ``cache_digest()`` enters the cache keys of the tasks that take this reference as input.
    """

    kind: str
    path: str
    sha256: str
    item: int | None = None
    status: RefStatus = RefStatus.OK
    numbers: dict[str, Any] = field(default_factory=dict)
    missing: Missing | None = None
    detail: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", RefStatus(self.status))

    @property
    def ok(self) -> bool:
        return self.status is RefStatus.OK

    @property
    def instance(self) -> InstanceId:
        """The instance of a per-instance reference (ValueError for a scene-level one)."""
        if self.item is None:
            raise ValueError(f"{self.kind} reference {self.path} belongs to no instance")
        return InstanceId(int(self.item))

    def cache_digest(self) -> dict[str, str]:
        """What of this reference a downstream cache key depends on: the content hash and the status."""
        return {"sha256": self.sha256, "status": self.status.value}

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "path": self.path,
            "sha256": self.sha256,
            "item": None if self.item is None else int(self.item),
            "status": self.status.value,
            "numbers": dict(self.numbers),
            "missing": None if self.missing is None else self.missing.to_json(),
            "detail": dict(self.detail),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Ref:
        return cls(
            kind=str(d["kind"]),
            path=str(d["path"]),
            sha256=str(d["sha256"]),
            item=None if d.get("item") is None else int(d["item"]),
            status=RefStatus(d.get("status", "ok")),
            numbers=dict(d.get("numbers", {})),
            missing=Missing.from_json(d["missing"]) if d.get("missing") else None,
            detail=dict(d.get("detail", {})),
        )
