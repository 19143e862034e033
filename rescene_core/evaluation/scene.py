"""The exported scene of a run as the evaluation reads it: ``scene/scene.json`` (``ExportedScene``) with
each object's mesh, and the objects' meshes placed in the world.

Both the metrics (``evaluation.run``) and the HTML report (``evaluation.report_html``) start from here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np
import trimesh
from numpy.typing import NDArray

from rescene_core.exported_scene import ExportedScene
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId


@dataclass(frozen=True)
class LoadedScene:
    """scene.json with every object's mesh read: ``meshes[instance]`` = (vertices float64 [n, 3], faces
    int64 [m, 3]) in the asset frame."""

    scene: ExportedScene
    meshes: dict[InstanceId, tuple[NDArray[np.float64], NDArray[np.int64]]]

    def final_poses(self) -> dict[int, NDArray[np.float64]]:
        """Instance id -> world_from_asset [4, 4] after attachment."""
        return {int(o.instance): o.world_from_asset for o in self.scene.objects}

    def registered_poses(self) -> dict[int, NDArray[np.float64]]:
        """Instance id -> world_from_asset [4, 4] before attachment, where the export recorded it."""
        return {
            int(o.instance): o.registered_world_from_asset
            for o in self.scene.objects
            if o.registered_world_from_asset is not None
        }


def load_scene(run_dir: str | Path) -> LoadedScene:
    """The run's scene.json and its objects' meshes (FileNotFoundError when the run exported none)."""
    run = RunPaths(run_dir)
    scene = ExportedScene.read(run.scene_json)
    meshes = {}
    for obj in scene.objects:
        # force="mesh" always gives a Trimesh; the stubs type load() as any Geometry
        mesh = cast(trimesh.Trimesh, trimesh.load(run.scene / obj.mesh, force="mesh", process=False))
        meshes[obj.instance] = (np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64))
    return LoadedScene(scene, meshes)


def placed_meshes(
    loaded: LoadedScene, poses: dict[int, NDArray[np.float64]] | None = None
) -> dict[int, tuple[str, trimesh.Trimesh]]:
    """Instance id -> (label, mesh in the world frame) at ``poses`` (default: the final poses)."""
    poses = loaded.final_poses() if poses is None else poses
    out = {}
    for o in loaded.scene.objects:
        m = np.asarray(poses.get(int(o.instance), o.world_from_asset), np.float64)
        vertices, faces = loaded.meshes[o.instance]
        out[int(o.instance)] = (o.label, trimesh.Trimesh(vertices @ m[:3, :3].T + m[:3, 3], faces, process=False))
    return out


__all__ = ["LoadedScene", "load_scene", "placed_meshes"]
