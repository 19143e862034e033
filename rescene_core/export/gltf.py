"""glTF that follows the specification: +Y up, metres, named nodes, scene-graph relations in node ``extras``.

ReScene's world is z up; glTF is +Y up. ``scene.glb`` keeps every object's own transform (world_from_asset,
written as translation / rotation / uniform scale) and hangs all nodes under one root node,
``ROOT_NODE``, whose fixed rotation takes the z-up world to glTF's y-up frame (-90 degrees about x:
x -> x, y -> -z, z -> y). A viewer shows the room upright; a reader that wants world coordinates drops
the root node (or applies its inverse).

The per-object meshes ``objects/<node>.glb`` hold one mesh in its asset frame (the frame that
``world_from_asset`` in scene.json places) with no root rotation: they are the run's mesh store, read back
by the evaluation, not scenes to view.

The Khronos glTF validator (npm ``gltf-validator``) checks files: ``validate_gltf`` runs it with Node
through ``validate_gltf.cjs`` beside this module.
"""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from rescene_core.geometry import sim3

ROOT_NODE = "world_z_up"
"""Name of the root node of scene.glb that rotates the z-up world into glTF's +Y-up frame."""
YUP_FROM_ZUP_QUAT_XYZW = (-float(np.sqrt(0.5)), 0.0, 0.0, float(np.sqrt(0.5)))
"""The root node's rotation: -90 degrees about x (glTF quaternion order x, y, z, w)."""
VALIDATOR_SCRIPT = Path(__file__).with_name("validate_gltf.cjs")
"""Node script that prints the Khronos validator's report of one file as JSON."""

_GLB_MAGIC = 0x46546C67
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942


def split_glb(data: bytes) -> tuple[dict[str, Any], bytes]:
    """(JSON document, binary chunk) of a GLB file's bytes."""
    magic, version, _length = struct.unpack_from("<III", data, 0)
    if magic != _GLB_MAGIC or version != 2:
        raise ValueError("not a glTF 2.0 binary (GLB) file")
    json_len, json_type = struct.unpack_from("<II", data, 12)
    if json_type != _CHUNK_JSON:
        raise ValueError("GLB: the first chunk is not JSON")
    doc = json.loads(data[20 : 20 + json_len])
    offset = 20 + json_len
    binary = b""
    if offset + 8 <= len(data):
        bin_len, bin_type = struct.unpack_from("<II", data, offset)
        if bin_type == _CHUNK_BIN:
            binary = data[offset + 8 : offset + 8 + bin_len]
    return doc, binary


def join_glb(doc: dict[str, Any], binary: bytes) -> bytes:
    """GLB bytes from a JSON document and a binary chunk (both padded to 4 bytes as the format requires)."""
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary = binary + b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(text), _CHUNK_JSON) + text
    if binary:
        chunks += struct.pack("<II", len(binary), _CHUNK_BIN) + binary
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(chunks)) + chunks


def trs_from_matrix(matrix: np.ndarray) -> dict[str, list[float]]:
    """glTF node ``translation`` / ``rotation`` (x, y, z, w) / ``scale`` of a Sim(3) float64 [4, 4].

    A matrix that is not a uniform-scale rotation (shear, reflection) is replaced by the nearest one
    (polar decomposition), so the node stays a valid TRS.
    """
    m = np.asarray(matrix, dtype=np.float64)
    linear = m[:3, :3]
    scale = sim3.scale_of(linear) or 1.0
    u, _, vt = np.linalg.svd(linear / scale)
    rot = u @ vt
    if np.linalg.det(rot) < 0:
        u[:, -1] *= -1
        rot = u @ vt
    out: dict[str, list[float]] = {}
    if np.any(np.abs(m[:3, 3]) > 0):
        out["translation"] = [float(x) for x in m[:3, 3]]
    quat = Rotation.from_matrix(rot).as_quat()
    if not np.allclose(quat, [0, 0, 0, 1]):
        out["rotation"] = [float(x) for x in quat / np.linalg.norm(quat)]
    if abs(scale - 1.0) > 1e-12:
        out["scale"] = [scale] * 3
    return out


def restructure_scene(data: bytes, extras: dict[str, dict[str, Any]], scene_extras: dict[str, Any]) -> bytes:
    """Rewrite a trimesh scene GLB: node matrices as TRS, every top node under the z-up -> y-up root node,
    ``extras`` (node name -> JSON object) on the named nodes, ``scene_extras`` on the scene."""
    doc, binary = split_glb(data)
    nodes = doc.setdefault("nodes", [])
    for node in nodes:
        if "matrix" in node:
            matrix = np.asarray(node.pop("matrix"), dtype=np.float64).reshape(4, 4).T  # glTF is column-major
            node.update(trs_from_matrix(matrix))
        if node.get("name") in extras:
            node["extras"] = extras[node["name"]]
    scene = doc["scenes"][doc.get("scene", 0)]
    nodes.append({"name": ROOT_NODE, "rotation": list(YUP_FROM_ZUP_QUAT_XYZW), "children": scene.get("nodes", [])})
    scene["nodes"] = [len(nodes) - 1]
    scene["extras"] = scene_extras
    return join_glb(doc, binary)


def object_glb(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """A GLB of one mesh in its own (asset) frame."""
    mesh = trimesh.Trimesh(np.asarray(vertices), np.asarray(faces), process=False)
    data = mesh.export(file_type="glb")
    assert isinstance(data, bytes)  # trimesh exports a binary format as bytes
    return data


def scene_glb(scene: trimesh.Scene, extras: dict[str, dict[str, Any]], scene_extras: dict[str, Any]) -> bytes:
    """The GLB of a z-up world ``scene`` (trimesh), converted to +Y up with node extras (see module doc)."""
    return restructure_scene(scene.export(file_type="glb"), extras, scene_extras)


@dataclass(frozen=True)
class GltfValidation:
    """What the Khronos validator said about one file (severity 0 error, 1 warning, 2 info, 3 hint)."""

    path: str
    errors: int
    warnings: int
    messages: list[dict[str, Any]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.errors == 0


def validate_gltf(path: str | Path, timeout: float = 120.0) -> GltfValidation:
    """Run the Khronos glTF validator on ``path`` (needs ``node`` and the npm package ``gltf-validator``,
    which ``make setup`` installs). Raises RuntimeError naming what is missing."""
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        raise RuntimeError("the glTF validator needs Node.js: install the Debian package 'nodejs' (make setup)")
    done = subprocess.run(
        [node, str(VALIDATOR_SCRIPT), str(path)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=Path(__file__).resolve().parents[2],
    )
    if done.returncode != 0:
        detail = done.stderr.strip().splitlines()[-1:] or ["no output"]
        hint = " (run `npm install` at the repository root)" if "Cannot find module" in done.stderr else ""
        raise RuntimeError(f"glTF validator failed on {path}: {detail[0]}{hint}")
    report = json.loads(done.stdout)
    issues = report.get("issues", {})
    return GltfValidation(
        str(path), int(issues.get("numErrors", 0)), int(issues.get("numWarnings", 0)), issues.get("messages", [])
    )
