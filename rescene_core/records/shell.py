"""The room shell: floor and wall planes, the floor polygon, which polygon edges have an observed wall."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon


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
