"""The exported scene of a run as the evaluation reads it: ``scene/scene.json`` with each object's mesh,
and the objects' meshes placed in the world at their final poses.

Both the metrics (``evaluation.run``) and the HTML report (``evaluation.report_html``) start from here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

import numpy as np
import trimesh

from rescene_core.io import read_json
from rescene_core.paths import RunPaths


def load_scene(run_dir: str | Path) -> dict[str, Any]:
    """scene.json with each object's mesh loaded: objects[i]["vertices"], ["faces"] (asset frame)."""
    run = RunPaths(run_dir)
    scene_dir, path = run.scene, run.scene_json
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist; the run has not exported a scene (run `rescene run` first)")
    doc = read_json(path)
    for obj in doc["objects"]:
        # force="mesh" always gives a Trimesh; the stubs type load() as any Geometry
        mesh = cast(trimesh.Trimesh, trimesh.load(scene_dir / obj["mesh"], force="mesh", process=False))
        obj["vertices"] = np.asarray(mesh.vertices, dtype=np.float64)
        obj["faces"] = np.asarray(mesh.faces, dtype=np.int64)
    return doc


def placed_meshes(doc: dict[str, Any]) -> dict[int, tuple[str, trimesh.Trimesh]]:
    """Instance id -> (label, mesh in the world frame at its final pose) of a loaded scene.json."""
    out = {}
    for o in doc["objects"]:
        m = np.asarray(o["world_from_asset"], np.float64)
        verts = np.asarray(o["vertices"]) @ m[:3, :3].T + m[:3, 3]
        out[int(o["instance"])] = (o["label"], trimesh.Trimesh(verts, np.asarray(o["faces"]), process=False))
    return out


__all__ = ["load_scene", "placed_meshes"]
