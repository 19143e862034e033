"""`rescene bench sim`: the simulation exports and the physics check on synthetic scenes.

Two layouts per (preset, seed):
  gt: the synthetic generator's ground-truth layout (its meshes, poses and relations, objects indexed by
      object id), the ceiling of what the exporter can achieve: it must come out stable (aim >= 0.99,
      t=0 penetration <= 5 mm) or the exporter is wrong.
  pipeline: the real pipeline's output (``rescene run`` on a capture written by ``write_synth``;
      captures and runs under WORK/captures and WORK/runs are reused, the same layout as the assembly
      suite), exported again with the current exporter and measured as it is.
Seed sets: the development seeds (``--seeds``, 0-4 by default: the seeds development decisions are made
on) and the held-out seeds (``--held-out``, e.g. 100-119: reported as they come), each summarised on its
own, per preset and layout, never pooled into one mean.
Per layout: export seconds (GLB, MJCF, USD, report; decompositions cached on the mesh hash under
WORK/convex_cache, so a first run pays CoACD and later runs do not: ``decompose_s_per_object`` counts
only the meshes decomposed in this run), collision pieces per object, and the physics check's stable
fraction (over all free objects, and the lowest scene's), t=0 penetration (max, mean), objects fallen
through and escaped, simulation seconds. With ``--shake`` the same MJCF is checked again with the room
shaken (``shake_check``) and the stable fraction under shake is reported beside the calm one. With
``newton`` the same scene's ``scene.usda`` is checked in Newton too (``rescene_core/sim/newton_check.py``,
calm) and its stable fraction is reported beside MuJoCo's, with the objects the engines disagree on.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.bench import format_seeds, seed_sets
from rescene_core.bench.runs import pipeline_run, synth_capture
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.export.scene import export_run
from rescene_core.exported_scene import ExportedScene
from rescene_core.io import read_json
from rescene_core.paths import RunPaths
from rescene_core.sim import SimcheckConfig, SimcheckResult, simcheck, simcheck_run

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


def shake_check(run_dir: Path) -> SimcheckResult:
    """The physics check of ``run_dir``'s MJCF with the room shaken (``SimcheckConfig(shake=True)``: 1 s of
    horizontal shaking, peak 3 m/s^2, then settling, 2 s in all, shake seed 0), the same room as the calm
    check. Nothing is written to the run: its ``sim/simcheck.json`` stays the calm check."""
    run_paths = RunPaths(run_dir)
    shell = ExportedScene.read(run_paths.scene_json).shell if run_paths.scene_json.exists() else None
    result, _ = simcheck(run_paths.scene_mjcf, shell, SimcheckConfig(shake=True))
    return result


def _unstable(check: SimcheckResult) -> list[str]:
    return [o.node for o in check.objects if o.kind == "free" and not o.stable]


def measure_scene(
    seed_set: str,
    preset: str,
    seed: int,
    layout: str,
    work_dir: Path,
    config: ExportConfig,
    shake: bool,
    newton: bool = False,
) -> dict[str, Any]:
    """One layout of one scene exported and checked: calm, shaken too with ``shake``, in Newton too with
    ``newton``. An export or a calm check that fails is recorded as ``error``; a shaken check that diverges
    as ``shake_error``, a Newton check that fails as ``newton_error``."""
    build = gt_scene if layout == "gt" else pipeline_scene
    entry: dict[str, Any] = {"seed_set": seed_set, "preset": preset, "seed": seed, "layout": layout}
    try:
        entry.update(build(preset, seed, work_dir, config))
        check = simcheck_run(entry["run_dir"], SimcheckConfig())
    except (RuntimeError, OSError, ValueError) as err:
        entry["error"] = str(err)
        return entry
    entry["simcheck"] = check.summary.to_json()
    entry["unstable"] = _unstable(check)
    if shake:
        try:
            shaken = shake_check(Path(entry["run_dir"]))
        except RuntimeError as err:  # the shaken simulation diverged
            entry["shake_error"] = str(err)
        else:
            entry["shake"] = shaken.summary.to_json()
            entry["unstable_shake"] = _unstable(shaken)
    if newton:
        from rescene_core.sim.newton_check import newton_simcheck_run

        try:
            record = newton_simcheck_run(entry["run_dir"], SimcheckConfig())
        except RuntimeError as err:  # diverged, or Newton is not installed
            entry["newton_error"] = str(err)
        else:
            entry["newton"] = record["summary"]
            entry["unstable_newton"] = [o["node"] for o in record["objects"] if o["kind"] == "free" and not o["stable"]]
            entry["disagreements"] = record.get("disagreements", [])
    return entry


def summarise(scenes: list[dict[str, Any]], shake: bool, newton: bool = False) -> dict[str, Any]:
    """The figures of one layout over ``scenes`` (one seed set, one preset): stable fraction over all free
    objects and the lowest scene's, under shake too with ``shake`` (over the scenes whose shaken check
    finished; ``shake_failed`` counts the others), t=0 penetration, fallen and escaped objects, seconds."""
    done = [s for s in scenes if "simcheck" in s]
    if not done:
        return {"scenes": 0, "failed": len(scenes)}
    free = sum(s["simcheck"]["free"] for s in done)
    per_obj = [s["decompose_s_per_object"] for s in done if s["decompose_s_per_object"] is not None]
    out = {
        "scenes": len(done),
        "failed": sum(1 for s in scenes if "error" in s),
        "free_objects": free,
        "stable_fraction": round(sum(s["simcheck"]["stable"] for s in done) / free, 4) if free else None,
        "stable_fraction_min": min(
            (s["simcheck"]["stable_fraction"] for s in done if s["simcheck"]["free"]), default=None
        ),
        "penetration_t0_max": max(s["simcheck"]["penetration_t0_max"] for s in done),
        "penetration_t0_mean": round(float(np.mean([s["simcheck"]["penetration_t0_mean"] for s in done])), 6),
        "fell_through": sum(s["simcheck"]["fell_through"] for s in done),
        "escaped": sum(s["simcheck"]["escaped"] for s in done),
        "pieces_per_object": round(float(np.mean([s["pieces_per_object"] for s in done])), 2),
        "decompose_s_per_object": round(float(np.mean(per_obj)), 2) if per_obj else None,
        "export_s_per_scene": round(float(np.mean([s["export_s"] for s in done])), 1),
        "simcheck_s_per_scene": round(float(np.mean([s["simcheck"]["seconds"] for s in done])), 2),
    }
    if shake:
        shaken = [s for s in done if "shake" in s]
        shaken_free = sum(s["shake"]["free"] for s in shaken)
        out |= {
            "stable_fraction_shake": (
                round(sum(s["shake"]["stable"] for s in shaken) / shaken_free, 4) if shaken_free else None
            ),
            "stable_fraction_shake_min": min(
                (s["shake"]["stable_fraction"] for s in shaken if s["shake"]["free"]), default=None
            ),
            "fell_through_shake": sum(s["shake"]["fell_through"] for s in shaken),
            "escaped_shake": sum(s["shake"]["escaped"] for s in shaken),
            "shake_failed": len(done) - len(shaken),
        }
    if newton:
        checked = [s for s in done if "newton" in s]
        newton_free = sum(s["newton"]["free"] for s in checked)
        mujoco_free = sum(s["simcheck"]["free"] for s in checked)
        out |= {
            "stable_fraction_newton": (
                round(sum(s["newton"]["stable"] for s in checked) / newton_free, 4) if newton_free else None
            ),
            # MuJoCo's over the same scenes, so the two columns compare like with like
            "stable_fraction_mujoco_same": (
                round(sum(s["simcheck"]["stable"] for s in checked) / mujoco_free, 4) if mujoco_free else None
            ),
            "disagreements": sum(len(s.get("disagreements", [])) for s in checked),
            "newton_failed": len(done) - len(checked),
            "newton_s_per_scene": (
                round(float(np.mean([s["newton"]["seconds"] for s in checked])), 1) if checked else None
            ),
        }
    return out


def run(
    seeds: list[int],
    preset: str,
    work_dir: Path,
    held_out: list[int] | None = None,
    shake: bool = False,
    newton: bool = False,
) -> dict[str, Any]:
    """Both layouts of every scene of ``preset`` (``all``: standard and cluttered) on the development
    ``seeds`` and on the ``held_out`` seeds, checked calm and, with ``shake``, shaken, and with ``newton``
    in Newton too; the summary has one block per seed set (``seed_sets``), each with its seeds and the
    figures per preset and layout."""
    sets = seed_sets(seeds, held_out)
    presets = ("standard", "cluttered") if preset == "all" else (preset,)
    config = ExportConfig(decomposition_cache=str(work_dir / "convex_cache"))
    scenes = [
        measure_scene(seed_set, p, seed, layout, work_dir, config, shake, newton)
        for seed_set, set_seeds in sets.items()
        for p in presets
        for seed in set_seeds
        for layout in LAYOUTS
    ]
    summary: dict[str, dict[str, Any]] = {}
    for seed_set, set_seeds in sets.items():
        block: dict[str, Any] = {"seeds": set_seeds}
        for p in presets:
            block[p] = {
                layout: summarise(
                    [s for s in scenes if (s["seed_set"], s["preset"], s["layout"]) == (seed_set, p, layout)],
                    shake,
                    newton,
                )
                for layout in LAYOUTS
            }
        summary[seed_set] = block
    return {
        "scenes": scenes,
        "summary": summary,
        "shake": shake,
        "newton": newton,
        "aims": {
            "gt_stable": 0.99,
            "gt_penetration_m": 0.005,
            "pipeline_stable": 0.95,
            "pipeline_stable_per_scene": 0.9,
            "pipeline_penetration_m": 0.01,
            "newton_vs_mujoco_stable": 0.1,
        },
    }


def _cell(value: float | None, width: int, scale: float = 1.0, digits: int = 3, unit: str = "") -> str:
    text = "-" if value is None else f"{value * scale:.{digits}f}{unit}"
    return f"{text:>{width}}"


SET_NOTES = {"development": "development decisions are made on these", "held_out": "reported as they come"}


def table(result: dict[str, Any]) -> str:
    """One row per seed set, preset and layout (seed sets never pooled); the shaken stable fraction beside
    the calm one when the suite ran with ``shake``; then the unstable objects and failures of each scene."""
    summary = result["summary"]
    sets = "; ".join(
        f"{name} seeds {format_seeds(block['seeds'])} ({SET_NOTES[name]})" for name, block in summary.items()
    )
    if "held_out" not in summary:
        sets += "; no held-out seeds (--held-out)"
    head = (
        f"{'seeds':<11} {'preset':<9} {'layout':<8} {'scenes':>6} {'free':>5} {'stable':>7} {'worst':>6} "
        f"{'shaken':>7} {'worst':>6} {'pen max':>8} {'pen mean':>9} {'fell':>5} {'escaped':>7} {'pieces':>7} "
        f"{'dec s/obj':>9} {'export s':>9} {'sim s':>6} {'newton':>7} {'mujoco':>7} {'differ':>6}"
    )
    lines = [f"sim bench, preset {result.get('preset')}: {sets}", head]
    for name, block in summary.items():
        for preset, layouts in block.items():
            if preset == "seeds":
                continue
            for layout, s in layouts.items():
                if not s["scenes"]:
                    lines.append(f"{name:<11} {preset:<9} {layout:<8} {0:>6}   (all {s['failed']} failed)")
                    continue
                lines.append(
                    f"{name:<11} {preset:<9} {layout:<8} {s['scenes']:>6} {s['free_objects']:>5} "
                    f"{_cell(s['stable_fraction'], 7)} {_cell(s['stable_fraction_min'], 6, digits=2)} "
                    f"{_cell(s.get('stable_fraction_shake'), 7)} {_cell(s.get('stable_fraction_shake_min'), 6, digits=2)} "
                    f"{_cell(s['penetration_t0_max'], 8, 1000, 1, 'mm')} {_cell(s['penetration_t0_mean'], 9, 1000, 2, 'mm')} "
                    f"{s['fell_through']:>5} {s['escaped']:>7} {s['pieces_per_object']:>7.1f} "
                    f"{_cell(s['decompose_s_per_object'], 9, digits=1)} {s['export_s_per_scene']:>9.1f} "
                    f"{s['simcheck_s_per_scene']:>6.2f} {_cell(s.get('stable_fraction_newton'), 7)} "
                    f"{_cell(s.get('stable_fraction_mujoco_same'), 7)} {s.get('disagreements', '-'):>6}"
                )
    lines.append(
        "stable: calm, 2 s under gravity; shaken: the room shaken 1 s (peak 3 m/s^2) then 1 s settling"
        + ("" if result.get("shake") else " (not run: --shake)")
        + "; worst: the lowest scene's; newton: calm stable fraction in Newton (XPBD, scene.usda), mujoco: "
        + "MuJoCo's over the same scenes, differ: objects stable in one engine only"
        + ("" if result.get("newton") else " (not run: --newton)")
    )
    for s in result["scenes"]:
        where = f"  {s.get('seed_set', 'development')} {s['layout']} {s['preset']} seed {s['seed']}"
        if "error" in s:
            lines.append(f"{where}: ERROR {s['error'].splitlines()[0]}")
            continue
        if s.get("unstable"):
            lines.append(f"{where}: unstable {', '.join(s['unstable'])}")
        if s.get("unstable_shake"):
            lines.append(f"{where}: unstable under shake {', '.join(s['unstable_shake'])}")
        if "shake_error" in s:
            lines.append(f"{where}: shaken check ERROR {s['shake_error'].splitlines()[0]}")
        if "newton_error" in s:
            lines.append(f"{where}: Newton check ERROR {s['newton_error'].splitlines()[0]}")
        for d in s.get("disagreements", []):
            lines.append(
                f"{where}: {d['node']} stable in {'MuJoCo' if d['stable_mujoco'] else 'Newton'} only "
                f"({d['drift_mujoco'] * 100:.1f} vs {d['drift_newton'] * 100:.1f} cm): {'; '.join(d['reasons'])}"
            )
    return "\n".join(lines)
