"""`rescene bench sim`: the simulation exports and the physics check on synthetic scenes.

Two layouts per (preset, seed):
  gt: the synthetic generator's ground-truth layout (its meshes, poses and relations, objects indexed by
      object id), the ceiling of what the exporter can achieve: it must come out stable (aim >= 0.99,
      t=0 penetration <= 5 mm) or the exporter is wrong.
  pipeline: the real pipeline's output (``rescene run`` on a capture written by ``write_synth``;
      captures and runs under WORK/captures and WORK/runs are reused, the same layout as the assembly
      suite), exported again with the current exporter and measured as it is.
Per layout: export seconds (GLB, MJCF, USD, report; decompositions cached on the mesh hash under
WORK/convex_cache, so a first run pays CoACD and later runs do not: ``decompose_s_per_object`` counts
only the meshes decomposed in this run), collision pieces per object, and the physics check's stable
fraction, t=0 penetration (max, mean), objects fallen through and escaped, simulation seconds.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.bench.runs import pipeline_run, synth_capture
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.scene import export_run
from rescene_core.io import read_json
from rescene_core.paths import RunPaths
from rescene_core.sim import SimcheckConfig, simcheck_run

LAYOUTS = ("gt", "pipeline")


def _export_figures(run: RunPaths, seconds: float) -> dict[str, Any]:
    report = read_json(run.export_report)
    objs = report["objects"]
    fresh = [o["seconds_decomposition"] for o in objs if not o.get("decomposition_cached")]
    return {
        "objects": len(objs),
        "export_s": round(seconds, 2),
        "pieces_per_object": round(float(np.mean([o["collision_pieces"] for o in objs])), 2) if objs else 0.0,
        "decomposed": len(fresh),
        "decompose_s_per_object": round(float(np.mean(fresh)), 2) if fresh else None,
        "fallbacks": sum(1 for o in objs if o["collision_method"] not in ("coacd", "components", "shell")),
        "exact": sum(1 for o in objs if o["collision_method"] == "components"),
        "guessed": report["guessed"],
    }


def gt_scene(preset: str, seed: int, work_dir: Path, config: ExportConfig) -> dict[str, Any]:
    from rescene_core.bench.assembly import ground_truth_layout

    objects, graph, shell, _ = ground_truth_layout(preset, seed)
    run = work_dir / "gt" / f"{preset}_seed{seed}"
    shutil.rmtree(run, ignore_errors=True)
    export_objects = [
        ExportObject(int(i), o.label, o.vertices, o.faces, o.world_from_asset) for i, o in objects.items()
    ]
    start = time.perf_counter()
    export_scene(RunPaths(run).scene, export_objects, shell, graph, [], config)
    return {"run_dir": str(run), **_export_figures(RunPaths(run), time.perf_counter() - start)}


def pipeline_scene(preset: str, seed: int, work_dir: Path, config: ExportConfig) -> dict[str, Any]:
    run = pipeline_run(synth_capture(work_dir, preset, seed), work_dir / "runs" / f"{preset}_seed{seed}")
    start = time.perf_counter()
    export_run(run, config)
    return {"run_dir": str(run), **_export_figures(RunPaths(run), time.perf_counter() - start)}


def run(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    presets = ("standard", "cluttered") if preset == "all" else (preset,)
    config = ExportConfig(decomposition_cache=str(work_dir / "convex_cache"))
    scenes = []
    for p in presets:
        for seed in seeds:
            for layout, build in (("gt", gt_scene), ("pipeline", pipeline_scene)):
                entry: dict[str, Any] = {"preset": p, "seed": seed, "layout": layout}
                try:
                    entry.update(build(p, seed, work_dir, config))
                    check = simcheck_run(entry["run_dir"], SimcheckConfig())
                    entry["simcheck"] = check.summary.to_json()
                    entry["unstable"] = [o.node for o in check.objects if o.kind == "free" and not o.stable]
                except (RuntimeError, OSError, ValueError) as err:
                    entry["error"] = str(err)
                scenes.append(entry)
    summary = {}
    for layout in LAYOUTS:
        done = [s for s in scenes if s["layout"] == layout and "simcheck" in s]
        if not done:
            continue
        free = sum(s["simcheck"]["free"] for s in done)
        per_obj = [s["decompose_s_per_object"] for s in done if s["decompose_s_per_object"] is not None]
        summary[layout] = {
            "scenes": len(done),
            "failed": sum(1 for s in scenes if s["layout"] == layout and "error" in s),
            "free_objects": free,
            "stable_fraction": round(sum(s["simcheck"]["stable"] for s in done) / free, 4) if free else None,
            "penetration_t0_max": max(s["simcheck"]["penetration_t0_max"] for s in done),
            "penetration_t0_mean": round(float(np.mean([s["simcheck"]["penetration_t0_mean"] for s in done])), 6),
            "fell_through": sum(s["simcheck"]["fell_through"] for s in done),
            "escaped": sum(s["simcheck"]["escaped"] for s in done),
            "pieces_per_object": round(float(np.mean([s["pieces_per_object"] for s in done])), 2),
            "decompose_s_per_object": round(float(np.mean(per_obj)), 2) if per_obj else None,
            "export_s_per_scene": round(float(np.mean([s["export_s"] for s in done])), 1),
            "simcheck_s_per_scene": round(float(np.mean([s["simcheck"]["seconds"] for s in done])), 2),
        }
    return {
        "scenes": scenes,
        "summary": summary,
        "aims": {"gt_stable": 0.99, "gt_penetration_m": 0.005, "pipeline_stable": 0.95, "pipeline_penetration_m": 0.01},
    }


def table(result: dict[str, Any]) -> str:
    head = (
        f"{'layout':<9} {'scenes':>6} {'free':>5} {'stable':>7} {'pen max':>8} {'pen mean':>9} {'fell':>5} "
        f"{'escaped':>7} {'pieces':>7} {'dec s/obj':>9} {'export s':>9} {'sim s':>6}"
    )
    lines = [f"sim bench, preset {result.get('preset')}, seeds {result.get('seeds')}", head]
    for layout, s in result["summary"].items():
        dec = "-" if s["decompose_s_per_object"] is None else f"{s['decompose_s_per_object']:.1f}"
        lines.append(
            f"{layout:<9} {s['scenes']:>6} {s['free_objects']:>5} {s['stable_fraction']:>7.3f} "
            f"{s['penetration_t0_max'] * 1000:>6.1f}mm {s['penetration_t0_mean'] * 1000:>7.2f}mm {s['fell_through']:>5} "
            f"{s['escaped']:>7} {s['pieces_per_object']:>7.1f} {dec:>9} {s['export_s_per_scene']:>9.1f} "
            f"{s['simcheck_s_per_scene']:>6.2f}"
        )
    for s in result["scenes"]:
        if "error" in s:
            lines.append(f"  {s['layout']} {s['preset']} seed {s['seed']}: ERROR {s['error'].splitlines()[0]}")
        elif s.get("unstable"):
            lines.append(f"  {s['layout']} {s['preset']} seed {s['seed']}: unstable {', '.join(s['unstable'])}")
    return "\n".join(lines)
