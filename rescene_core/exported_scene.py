"""``scene/scene.json``: the exported scene as a typed record, with its one writer and its one reader.

The export writes it (``rescene_core.export.scene``); the evaluation, the physics check, the VQA builder and
a re-export read it back through ``ExportedScene.read``. Poses are 4x4 ``world_from_asset`` Sim(3)
matrices in metres, world z up; each object's mesh (asset frame) is ``scene/<mesh>``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.io import read_json, write_bytes_atomic
from rescene_core.records import Completion, InstanceId, Missing, RoomShell, SceneGraph

SCENE_FORMAT = "rescene-scene"
SCENE_VERSION = 1

_FIELDS = ("format", "version", "units", "up", "objects", "graph", "shell", "shell_nodes", "missing")
"""scene.json's own top-level fields; any other top-level field is ``ExportedScene.extra``."""


class SceneFileError(ValueError):
    """scene.json is not an exported ReScene scene (another format or a newer version); names the file."""


@dataclass(frozen=True)
class ExportedObject:
    """One placed object of scene.json.

    node: its name in every export (rescene_core/names.py); label: the capture's label, verbatim.
    mesh: its mesh file relative to scene/ (asset frame). world_from_asset: final pose float64 [4, 4];
    scale: its uniform scale. registered_world_from_asset: the pose before attachment (None when unknown).
    parent, relation: its scene-graph edge in JSON form (``floor``, ``wall``, an instance id; ``rests-on``,
    ``mounts-on``), None without one. completions: the amodal completions the export added.
    """

    instance: InstanceId
    label: str
    node: str
    mesh: str
    world_from_asset: NDArray[np.float64]
    scale: float
    registered_world_from_asset: NDArray[np.float64] | None = None
    parent: int | str | None = None
    relation: str | None = None
    completions: tuple[Completion, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {
            "instance": int(self.instance),
            "label": self.label,
            "node": self.node,
            "mesh": self.mesh,
            "world_from_asset": np.asarray(self.world_from_asset, np.float64).tolist(),
            "scale": self.scale,
            "registered_world_from_asset": None
            if self.registered_world_from_asset is None
            else np.asarray(self.registered_world_from_asset).tolist(),
            "parent": self.parent,
            "relation": self.relation,
            "completions": [c.to_json() for c in self.completions],
        }

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ExportedObject:
        registered = d.get("registered_world_from_asset")
        return cls(
            instance=InstanceId(int(d["instance"])),
            label=str(d["label"]),
            node=str(d["node"]),
            mesh=str(d["mesh"]),
            world_from_asset=np.asarray(d["world_from_asset"], np.float64),
            scale=float(d["scale"]),
            registered_world_from_asset=None if registered is None else np.asarray(registered, np.float64),
            parent=d.get("parent"),
            relation=d.get("relation"),
            completions=tuple(Completion.from_json(c) for c in d.get("completions", ())),
        )


@dataclass(frozen=True)
class ExportedScene:
    """The content of scene.json. shell_nodes: the names of the room-shell meshes in scene.glb.
    extra: the other top-level fields the run added (``scene_id``, ``capture``, ``capture_sha256``)."""

    objects: tuple[ExportedObject, ...]
    graph: SceneGraph
    shell: RoomShell | None
    shell_nodes: tuple[str, ...] = ()
    missing: tuple[Missing, ...] = ()
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def capture(self) -> str | None:
        """The capture the run read (absolute path), when the run recorded it."""
        value = self.extra.get("capture")
        return str(value) if value else None

    def object(self, instance: int) -> ExportedObject:
        """The object of ``instance`` (KeyError when it was not placed)."""
        for o in self.objects:
            if o.instance == instance:
                return o
        raise KeyError(instance)

    def to_json(self) -> dict[str, Any]:
        return {
            "format": SCENE_FORMAT,
            "version": SCENE_VERSION,
            "units": "m",
            "up": "+z",
            "objects": [o.to_json() for o in self.objects],
            "graph": self.graph.to_json(),
            "shell": self.shell.to_json() if self.shell is not None else None,
            "shell_nodes": list(self.shell_nodes),
            "missing": [m.to_json() for m in self.missing],
            **self.extra,
        }

    @classmethod
    def from_json(cls, doc: Mapping[str, Any], source: str = "scene.json") -> ExportedScene:
        if doc.get("format", SCENE_FORMAT) != SCENE_FORMAT or int(doc.get("version", SCENE_VERSION)) > SCENE_VERSION:
            raise SceneFileError(
                f"{source}: format {doc.get('format')!r} version {doc.get('version')!r} is not a ReScene scene this "
                f"version reads ({SCENE_FORMAT!r} up to version {SCENE_VERSION}); export it again with `rescene run`"
            )
        return cls(
            objects=tuple(ExportedObject.from_json(o) for o in doc["objects"]),
            graph=SceneGraph.from_json(doc.get("graph") or {"edges": []}),
            shell=RoomShell.from_json(doc["shell"]) if doc.get("shell") else None,
            shell_nodes=tuple(doc.get("shell_nodes", ())),
            missing=tuple(Missing.from_json(m) for m in doc.get("missing", ())),
            extra={k: v for k, v in doc.items() if k not in _FIELDS},
        )

    def write(self, path: str | Path) -> Path:
        """Write scene.json atomically (indented JSON); returns the path."""
        return write_bytes_atomic(Path(path), json.dumps(self.to_json(), indent=2).encode())

    @classmethod
    def read(cls, path: str | Path) -> ExportedScene:
        """Read scene.json; FileNotFoundError that says how to make one, SceneFileError for another format."""
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(
                f"{path} does not exist; the run has not exported a scene (run `rescene run` first)"
            )
        return cls.from_json(read_json(path), str(path))
