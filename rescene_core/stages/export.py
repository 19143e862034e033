"""Stage ``export``: the attached scene as scene/scene.glb, scene.usda, mjcf/scene.xml, scene.json and scene/objects/."""

from __future__ import annotations

import dataclasses
import hashlib
import json

from rescene_core.capture import open_capture
from rescene_core.export import ExportConfig, export_scene, placed_objects
from rescene_core.export.simulation import export_simulation
from rescene_core.export.usd import load_usd
from rescene_core.io import hash_file, hash_tree, read_json
from rescene_core.paths import RunPaths
from rescene_core.records import Layout, Missing, Ref, SceneGraph, Stage
from rescene_core.stages import common, hooks
from rescene_core.stages.execution import executing, make_ref


def run(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    graph: Ref,
    layout: Ref,
    assets: list[Ref],
    poses: list[Ref],
    missing: list[Missing],
    config: ExportConfig,
) -> Ref:
    """Every export of the layout; ``missing``: the instances left out before attachment (the layout adds its own)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.EXPORT) as seg:
        cap = open_capture(capture.path, validate=False)
        layout_rec = Layout.from_json(read_json(run.root / layout.path))
        objects = placed_objects(common.placed_objects(run_dir, cap, assets, poses), layout_rec)
        all_missing = list(missing) + list(layout_rec.missing)
        shell_rec = common.load_shell(run_dir, shell)
        graph_rec = SceneGraph.from_json(read_json(run.root / graph.path))
        # the visual scene first (export_scene without the simulation exports), then the simulation exports as
        # export_scene adds them: work that reads only the visual scene starts in between and runs beside the
        # collision decomposition's worker processes (rescene_core/stages/hooks.py)
        hashes = export_scene(
            run.scene,
            objects,
            shell_rec,
            graph_rec,
            all_missing,
            config.model_copy(update={"simulation": False}),
            extra={"scene_id": cap.scene_id, "capture": capture.path, "capture_sha256": capture.sha256},
        )
        if config.simulation:
            _load_native_libraries()  # before anything runs beside the export
            hooks.visual_scene_written(str(run.root), capture.path)
            sim = export_simulation(run.scene, list(objects), shell_rec, graph_rec, all_missing, config)
            hashes.update({rel: hash_file(run.scene / rel) for rel in sim.files})
            hashes[sim.mjcf_dir] = hash_tree(run.scene / sim.mjcf_dir)
        seg.log("/metrics", {"stage": Stage.EXPORT, "metrics": {"objects": len(objects), "files": len(hashes)}})
        ref = make_ref(run_dir, run.scene_json, "scene", numbers={"objects": len(objects)}, detail={"files": hashes})
        # the reference stands for the whole scene/ directory: an MJCF or USD that changed while scene.json did
        # not (a collider setting) must re-run the physics check and the evaluation that read them
        return dataclasses.replace(ref, sha256=scene_digest(hashes))


def scene_digest(hashes: dict[str, str]) -> str:
    """sha256 over every exported file's path and sha256 (``export_scene``'s return value)."""
    return hashlib.sha256(json.dumps(hashes, sort_keys=True).encode()).hexdigest()


def _load_native_libraries() -> None:
    """Load the native libraries the simulation exports import on first use (OpenUSD, MuJoCo for the MJCF and
    the collider checks, Open3D for the decomposition's simplification) before work starts beside the export,
    for the reason ``load_usd`` gives: a library loaded in one thread while another runs numpy can deadlock."""
    load_usd()
    import mujoco  # noqa: F401
    import open3d  # noqa: F401
