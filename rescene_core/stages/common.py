"""Readers shared by the scene-level stage bodies: a run's room shell and placed objects from their references."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rescene_core.capture import Capture
from rescene_core.io import read_json
from rescene_core.records import Pose, Ref, RoomShell
from rescene_core.runlog import SceneObject
from rescene_core.stages.asset import load_asset_ref


def load_shell(run_dir: str | Path, ref: Ref) -> RoomShell:
    """The RoomShell behind a shell reference (shell.json)."""
    return RoomShell.from_json(read_json(Path(run_dir) / ref.path))


def placed_objects(run_dir: str | Path, cap: Capture, assets: list[Ref], poses: list[Ref]) -> list[SceneObject]:
    """The registered objects (asset mesh + registered pose) of every instance with an ok pose."""
    by_id = {int(a.instance): a for a in assets if a.ok}
    out = []
    for p in poses:
        i = int(p.instance)
        if not p.ok or i not in by_id:
            continue
        asset = load_asset_ref(run_dir, by_id[i])
        pose = Pose.from_json(read_json(Path(run_dir) / p.path)["pose"])
        vertices, faces = np.asarray(asset.vertices), np.asarray(asset.faces)
        out.append(SceneObject(i, cap.instance(i).label, vertices, faces, pose.world_from_asset))
    return out
