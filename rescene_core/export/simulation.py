"""The simulation exports of an assembled scene: MJCF (rescene_core/export/mjcf.py), USD
(rescene_core/export/usd.py) and ``scene/export_report.json``, every value the exporter guessed or
substituted, per object.

Paths, relative to the run's ``scene/`` directory, are the constants below.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rescene_core.export.collision import DecompositionSettings, decompose_all
from rescene_core.export.mjcf import build_spec, write_mjcf
from rescene_core.export.objects import ExportObject
from rescene_core.export.physics_tables import load_physics_table
from rescene_core.io import write_json_atomic
from rescene_core.records import Missing, RoomShell, SceneGraph

if TYPE_CHECKING:
    from rescene_core.export.scene import ExportConfig

MJCF_DIR = "mjcf"
"""The MJCF directory under scene/ (scene.xml and meshes/)."""
MJCF_FILE = "mjcf/scene.xml"
USD_FILE = "scene.usda"
USD_BINARY_FILE = "scene.usdc"
REPORT_FILE = "export_report.json"
REPORT_FORMAT = "rescene-export-report"


@dataclass(frozen=True)
class SimulationExport:
    """Files written (relative to scene/) and the export report (the JSON document)."""

    files: tuple[str, ...]
    report: dict[str, Any]


def decomposition_settings(config: ExportConfig) -> DecompositionSettings:
    return DecompositionSettings(
        threshold=config.coacd_threshold,
        max_pieces=config.coacd_max_pieces,
        max_faces=config.coacd_max_faces,
        timeout_s=config.coacd_timeout_s,
        workers=config.decomposition_workers,
        cache_dir=config.decomposition_cache,
    )


def _scale(obj: ExportObject) -> float:
    m = np.asarray(obj.world_from_asset, np.float64)
    return float(np.cbrt(abs(np.linalg.det(m[:3, :3])))) or 1.0


def export_simulation(
    out_dir: str | Path,
    objects: list[ExportObject],
    shell: RoomShell | None,
    graph: SceneGraph | None,
    missing: Iterable[Missing],
    config: ExportConfig,
) -> SimulationExport:
    """Write the MJCF, the USD stage and export_report.json under ``out_dir`` (the run's scene/).

    One object's bad mesh never stops the others: it gets a hull or box collider and a report entry.
    """
    from rescene_core.export.usd import write_usd

    out_dir = Path(out_dir)
    started = time.perf_counter()
    table = load_physics_table(config.physics_table)
    meshes = {o.node_name: (np.asarray(o.vertices, np.float64) * _scale(o), np.asarray(o.faces)) for o in objects}
    decompositions = decompose_all(meshes, decomposition_settings(config))
    decompose_s = time.perf_counter() - started
    mjcf_dir = out_dir / MJCF_DIR
    mjcf_dir.mkdir(parents=True, exist_ok=True)
    spec, bodies = build_spec(
        objects,
        shell,
        graph,
        decompositions,
        table,
        mjcf_dir,
        config.wall_height,
        config.wall_thickness,
        config.floor_thickness,
    )
    write_mjcf(spec, mjcf_dir)
    usd_rel = USD_BINARY_FILE if config.usd_binary else USD_FILE
    write_usd(out_dir / usd_rel, objects, shell, graph, decompositions, bodies, config)
    report = {
        "format": REPORT_FORMAT,
        "version": 1,
        "files": {"mjcf": MJCF_FILE, "usd": usd_rel},
        "physics_table": config.physics_table or "built-in (rescene_core/export/physics_tables.py)",
        "objects": [
            b.to_json()
            | {
                "seconds_decomposition": decompositions[b.node].seconds,
                "decomposition_cached": decompositions[b.node].cached,
            }
            for b in bodies
        ],
        "guessed": sum(1 for b in bodies if b.notes),
        "missing": [m.to_json() for m in missing],
        "seconds": {"decomposition": round(decompose_s, 3), "total": round(time.perf_counter() - started, 3)},
    }
    write_json_atomic(out_dir / REPORT_FILE, report)
    return SimulationExport((MJCF_FILE, usd_rel, REPORT_FILE), report)


def read_exported_scene(
    scene_dir: str | Path,
) -> tuple[list[ExportObject], RoomShell | None, SceneGraph, list[Missing], dict[str, Any]]:
    """The objects, shell, graph, missing instances and other scene.json fields of an exported scene/."""
    import trimesh

    from rescene_core.io import read_json

    scene_dir = Path(scene_dir)
    path = scene_dir / "scene.json"
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist; the run has not exported a scene (run `rescene run` first)")
    doc = read_json(path)
    objects = []
    for entry in doc["objects"]:
        mesh = trimesh.load(scene_dir / entry["mesh"], force="mesh", process=False)
        registered = entry.get("registered_world_from_asset")
        objects.append(
            ExportObject(
                int(entry["instance"]),
                str(entry["label"]),
                np.asarray(mesh.vertices, np.float64),
                np.asarray(mesh.faces, np.int64),
                np.asarray(entry["world_from_asset"], np.float64),
                None if registered is None else np.asarray(registered, np.float64),
            )
        )
    shell = RoomShell.from_json(doc["shell"]) if doc.get("shell") else None
    graph = SceneGraph.from_json(doc.get("graph", {"edges": []}))
    missing = [Missing.from_json(m) for m in doc.get("missing", [])]
    known = {"format", "version", "units", "up", "objects", "graph", "shell", "shell_nodes", "missing"}
    return objects, shell, graph, missing, {k: v for k, v in doc.items() if k not in known}


def export_run(run_dir: str | Path, config: ExportConfig) -> dict[str, Any]:
    """Write a run's scene/ exports again (GLB, scene.json, MJCF, USD, report) from its scene.json and
    objects/; returns {file: sha256}."""
    from rescene_core.export.scene import export_scene

    scene_dir = Path(run_dir) / "scene"
    objects, shell, graph, missing, extra = read_exported_scene(scene_dir)
    return export_scene(scene_dir, objects, shell, graph, missing, config, extra=extra)
