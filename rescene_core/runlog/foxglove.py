"""``foxglove.SceneUpdate`` messages (JSON encoding) showing the scene in Foxglove Studio's 3D panel.

One entity per object: a triangle list of its world-frame mesh and a cube for its oriented bounding
box; the room shell becomes a floor triangle list and one cube per wall. Frame ``world``; metres.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation
from shapely.geometry import Polygon
from shapely.ops import triangulate

from rescene_core.geometry import sim3
from rescene_core.names import node_name
from rescene_core.records import RoomShell

_VEC3 = {
    "type": "object",
    "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}},
    "required": ["x", "y", "z"],
}
_QUAT = {
    "type": "object",
    "properties": {k: {"type": "number"} for k in "xyzw"},
    "required": ["x", "y", "z", "w"],
}
_POSE = {
    "type": "object",
    "properties": {"position": _VEC3, "orientation": _QUAT},
    "required": ["position", "orientation"],
}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}, "required": ["r", "g", "b", "a"]}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}

SCENE_UPDATE_SCHEMA: dict[str, Any] = {
    "title": "foxglove.SceneUpdate",
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {"timestamp": _TIME, "type": {"type": "integer"}, "id": {"type": "string"}},
            },
        },
        "entities": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntity",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {
                        "type": "array",
                        "items": {
                            "type": "object",
                            "properties": {"key": {"type": "string"}, "value": {"type": "string"}},
                        },
                    },
                    "arrows": {"type": "array"},
                    "cubes": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.CubePrimitive",
                            "type": "object",
                            "properties": {"pose": _POSE, "size": _VEC3, "color": _COLOR},
                        },
                    },
                    "spheres": {"type": "array"},
                    "cylinders": {"type": "array"},
                    "lines": {"type": "array"},
                    "triangles": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.TriangleListPrimitive",
                            "type": "object",
                            "properties": {
                                "pose": _POSE,
                                "points": {"type": "array", "items": _VEC3},
                                "color": _COLOR,
                                "colors": {"type": "array", "items": _COLOR},
                                "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}},
                            },
                        },
                    },
                    "texts": {"type": "array"},
                    "models": {"type": "array"},
                },
            },
        },
    },
}
"""JSON schema of foxglove.SceneUpdate restricted to the primitives ReScene writes (cubes, triangles)."""


@dataclass(frozen=True)
class SceneObject:
    """One object to draw. vertices: float64 [v, 3] in the asset frame; faces: int64 [f, 3];
    world_from_asset: float64 [4, 4] Sim(3)."""

    instance: int
    label: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    world_from_asset: NDArray[np.float64]


def _time(ns: int) -> dict[str, int]:
    return {"sec": int(ns // 1_000_000_000), "nsec": int(ns % 1_000_000_000)}


def _color(key: int, alpha: float = 1.0) -> dict[str, float]:
    r, g, b = np.random.default_rng(key).uniform(0.25, 0.95, 3)
    return {"r": float(r), "g": float(g), "b": float(b), "a": alpha}


def _pose(position: NDArray, rotation: NDArray) -> dict[str, Any]:
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    p = np.asarray(position, dtype=np.float64)
    return {
        "position": {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])},
        "orientation": {"x": float(x), "y": float(y), "z": float(z), "w": float(w)},
    }


_IDENTITY_POSE = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


def _entity(entity_id: str, ns: int, metadata: dict[str, str]) -> dict[str, Any]:
    return {
        "timestamp": _time(ns),
        "frame_id": "world",
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": [{"key": k, "value": v} for k, v in metadata.items()],
        "arrows": [],
        "cubes": [],
        "spheres": [],
        "cylinders": [],
        "lines": [],
        "triangles": [],
        "texts": [],
        "models": [],
    }


def _triangles(points_world: NDArray, faces: NDArray, color: dict[str, float]) -> dict[str, Any]:
    pts = np.round(np.asarray(points_world, dtype=np.float64), 5)
    return {
        "pose": _IDENTITY_POSE,
        "points": [{"x": float(a), "y": float(b), "z": float(c)} for a, b, c in pts],
        "color": color,
        "colors": [],
        "indices": [int(i) for i in np.asarray(faces, dtype=np.int64).reshape(-1)],
    }


def object_entity(obj: SceneObject, ns: int) -> dict[str, Any]:
    """Entity named like the object's export node (rescene_core/names.py): world mesh as a triangle
    list plus its oriented bounding box as a cube."""
    m = np.asarray(obj.world_from_asset, dtype=np.float64)
    verts = np.asarray(obj.vertices, dtype=np.float64)
    world = verts @ m[:3, :3].T + m[:3, 3]
    ent = _entity(node_name(obj.instance, obj.label), ns, {"instance": str(obj.instance), "label": obj.label})
    color = _color(obj.instance)
    if len(verts) and len(obj.faces):
        ent["triangles"].append(_triangles(world, obj.faces, color))
    if len(verts):
        scale = sim3.scale_of(m) or 1.0
        rot = m[:3, :3] / scale
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        centre = m[:3, :3] @ ((lo + hi) / 2) + m[:3, 3]
        size = (hi - lo) * scale
        ent["cubes"].append(
            {
                "pose": _pose(centre, rot),
                "size": {"x": float(size[0]), "y": float(size[1]), "z": float(size[2])},
                "color": {**color, "a": 0.25},
            }
        )
    return ent


def shell_entities(shell: RoomShell, ns: int, wall_height: float, wall_thickness: float) -> list[dict[str, Any]]:
    """Floor polygon (triangulated, on the floor plane) and one cube per wall segment."""

    entities = []
    n = np.asarray(shell.floor.normal, dtype=np.float64)
    grey = {"r": 0.6, "g": 0.6, "b": 0.6, "a": 0.6}
    poly = Polygon(shell.floor_polygon)
    if poly.is_valid and poly.area > 0:
        pts: list[tuple[float, float, float]] = []
        for tri in triangulate(poly):
            if not tri.representative_point().within(poly):
                continue
            for x, y in list(tri.exterior.coords)[:3]:
                z = -(shell.floor.offset + n[0] * x + n[1] * y) / n[2] if abs(n[2]) > 1e-9 else 0.0
                pts.append((x, y, z))
        ent = _entity("shell_floor", ns, {"label": "floor"})
        if pts:
            ent["triangles"].append(_triangles(np.array(pts), np.arange(len(pts)).reshape(-1, 3), grey))
        entities.append(ent)
    floor_z = -shell.floor.offset / n[2] if abs(n[2]) > 1e-9 else 0.0
    for wall in shell.walls:
        (x0, y0), (x1, y1) = wall.segment
        length = float(np.hypot(x1 - x0, y1 - y0))
        if length <= 0:
            continue
        yaw = float(np.arctan2(y1 - y0, x1 - x0))
        rot = Rotation.from_euler("z", yaw).as_matrix()
        wn = np.asarray(wall.plane.normal, dtype=np.float64)
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, floor_z + wall_height / 2]) - wn * wall_thickness / 2
        ent = _entity(f"shell_wall_{wall.id}", ns, {"label": "wall", "wall_id": str(wall.id)})
        ent["cubes"].append(
            {
                "pose": _pose(centre, rot),
                "size": {"x": length, "y": wall_thickness, "z": wall_height},
                "color": {**grey, "a": 0.3},
            }
        )
        entities.append(ent)
    return entities


def scene_update(
    objects: Iterable[SceneObject],
    shell: RoomShell | None,
    ns: int,
    wall_height: float,
    wall_thickness: float,
) -> dict[str, Any]:
    """A full snapshot: delete everything on the topic, then add one entity per object and the shell."""
    entities = [object_entity(o, ns) for o in objects]
    if shell is not None:
        entities += shell_entities(shell, ns, wall_height, wall_thickness)
    return {"deletions": [{"timestamp": _time(ns), "type": 1, "id": ""}], "entities": entities}
