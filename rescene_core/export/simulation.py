"""The simulation exports of an assembled scene: MJCF (rescene_core/export/mjcf.py), USD
(rescene_core/export/usd.py) and ``scene/export_report.json``, every value the exporter guessed or
substituted, per object, and every completion attachment added to an object's mesh (``completions``: a
support plane's board, a base, an amodal base under an object seen only from above; its node, instance,
label, kind, source and collider; a cut is applied to the mesh itself and is not listed).

The files' names under the scene directory are the run directory's (rescene_core/paths.py), taken
relative to its ``scene/``.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core import paths
from rescene_core.colliders import edit_colliders, find_hollow
from rescene_core.colliders.decompose import Decomposition, DecompositionSettings, decompose_all
from rescene_core.config import ExportConfig
from rescene_core.export.mjcf import MIN_MASS, body_kind, build_spec, closed_volume, write_mjcf
from rescene_core.export.objects import ExportObject
from rescene_core.export.physics_tables import load_physics_table
from rescene_core.export.structure import StructureRule, built_in
from rescene_core.export.usd import write_usd
from rescene_core.geometry.sim3 import scale_of
from rescene_core.io import write_json_atomic
from rescene_core.records import Missing, RoomShell, SceneGraph


def _in_scene(template: str) -> str:
    """A run-directory path's name under scene/ (``scene/mjcf/`` -> ``mjcf``)."""
    return paths.in_folder("", template, paths.SCENE).as_posix()


REPORT_FORMAT = "rescene-export-report"


@dataclass(frozen=True)
class SimulationExport:
    """Files written (relative to scene/) and the export report (the JSON document)."""

    files: tuple[str, ...]
    report: dict[str, Any]
    mjcf_dir: str = _in_scene(paths.SCENE_MJCF_DIR)


def decomposition_settings(config: ExportConfig) -> DecompositionSettings:
    return DecompositionSettings(
        threshold=config.coacd_threshold,
        max_pieces=config.coacd_max_pieces,
        max_faces=config.coacd_max_faces,
        timeout_s=config.coacd_timeout_s,
        workers=config.decomposition_workers,
        cache_dir=config.decomposition_cache,
        hull_below_m=config.hull_below_m,
    )


def structure_rule(config: ExportConfig) -> StructureRule:
    return StructureRule(
        labels=tuple(config.structure_labels),
        top_height_m=config.structure_top_height_m,
        wall_gap_m=config.structure_wall_gap_m,
        min_length_m=config.structure_min_length_m,
    )


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
    out_dir = Path(out_dir)
    mjcf_file, report_file = _in_scene(paths.SCENE_MJCF), _in_scene(paths.EXPORT_REPORT)
    started = time.perf_counter()
    table = load_physics_table(config.physics_table)
    hollow = find_hollow(objects, graph, shell)  # their pieces are a shell: nothing to decompose
    meshes = {
        o.node_name: (np.asarray(o.vertices, np.float64) * (scale_of(o.world_from_asset) or 1.0), np.asarray(o.faces))
        for o in objects
        if o.node_name not in hollow
    }
    decompositions = decompose_all(meshes, decomposition_settings(config))
    for name in hollow:
        decompositions[name] = Decomposition((), "shell", 0.0, False, ("hollow shell and boards, no decomposition",))
    decompose_s = time.perf_counter() - started
    pieces = {name: list(dec.pieces) for name, dec in decompositions.items()}
    fixed_structure = built_in(objects, graph, shell, structure_rule(config))
    kinds = {o.node_name: body_kind(o.instance, graph, fixed_structure)[0] for o in objects}
    masses = {}
    for o in objects:
        density = table.lookup(o.label)[0]
        volume = closed_volume(np.asarray(o.vertices, np.float64) * (scale_of(o.world_from_asset) or 1.0), o.faces)[0]
        masses[o.node_name] = max(density * volume, MIN_MASS)
    methods = {n: d.method for n, d in decompositions.items()}
    edits = edit_colliders(objects, pieces, hollow, graph, kinds, methods, masses, shell)
    decompositions = {name: replace(dec, pieces=tuple(pieces[name])) for name, dec in decompositions.items()}
    mjcf_dir = out_dir / _in_scene(paths.SCENE_MJCF_DIR)
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
        fixed_structure,
    )
    write_mjcf(spec, mjcf_dir)
    usd_rel = _in_scene(paths.SCENE_USDC if config.usd_binary else paths.SCENE_USDA)
    write_usd(out_dir / usd_rel, objects, shell, graph, decompositions, bodies, config)
    report = {
        "format": REPORT_FORMAT,
        "version": 1,
        "files": {"mjcf": mjcf_file, "usd": usd_rel},
        "physics_table": config.physics_table or "built-in (rescene_core/export/physics_tables.py)",
        "objects": [
            b.to_json()
            | {
                "seconds_decomposition": decompositions[b.node].seconds,
                "decomposition_cached": decompositions[b.node].cached,
                "colliders_from_layout": edits[b.node].to_json(),
            }
            for b in bodies
        ],
        "guessed": sum(1 for b in bodies if b.notes),
        "completions_added": sum(len(e.completions) for e in edits.values()),
        "completions": [
            {"node": b.node, "instance": b.instance, "label": b.label} | entry
            for b in bodies
            for entry in edits[b.node].completions
        ],
        "hollow_shells": sorted(n for n, e in edits.items() if e.hollow),
        "seats_cut": sum(sum(1 for s in e.seats if s.get("cut")) for e in edits.values()),
        "footings": sorted(n for n, e in edits.items() if e.footing and e.footing.get("band_m")),
        "missing": [m.to_json() for m in missing],
        "seconds": {"decomposition": round(decompose_s, 3), "total": round(time.perf_counter() - started, 3)},
    }
    write_json_atomic(out_dir / report_file, report)
    return SimulationExport((mjcf_file, usd_rel, report_file), report)
