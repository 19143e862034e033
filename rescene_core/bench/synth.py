"""`rescene bench synth`: time to generate and write synthetic captures, and what they contain.

Per preset and seed: wall seconds of `rescene synth` (generation, writing the capture, the pictures),
seconds per frame, process CPU seconds, the step timings of ``make_scene``, and the properties later
stages rely on: objects, instances, points, objects with >= 500 points, frames showing >= 5 object
instances, close-ups whose target object touches the image border, and the panoptic errors applied.
The aim (issue 3): a standard capture in at most 30 s on the 2-core development machine.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture.synth import make_scene, write_scene

AIM_STANDARD_SECONDS = 30.0
"""Aim for one standard capture, generation + writing + pictures (s)."""
DENSE_POINTS = 500
"""An object cloud counts as dense with at least this many points."""
MANY_INSTANCES = 5
"""A frame counts as busy when at least this many object instances are visible in it."""


def _content(scene) -> dict[str, Any]:
    a, gt = scene.arrays, scene.gt
    counts = np.diff(a.point_offsets)
    structural = {int(i.id) for i in a.instances if i.structural}
    obj_counts = [int(n) for i, n in zip(a.point_ids, counts) if int(i) not in structural]
    busy, cropped, closeups = 0, 0, 0
    for t in range(a.instance_masks.shape[0]):
        ids = np.unique(a.instance_masks[t])
        if len([i for i in ids if i and int(i) not in structural]) >= MANY_INSTANCES:
            busy += 1
        target = scene.plan.target_object[t]
        if target:
            closeups += 1
            m = scene.object_id_frames[t] == target
            if m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any():
                cropped += 1
    kinds: dict[str, int] = {}
    for e in scene.events:
        kinds[e["kind"]] = kinds.get(e["kind"], 0) + 1
    return {
        "objects": len(gt.objects),
        "categories": len({o.label for o in gt.objects}),
        "instances": len(a.instances),
        "points": int(len(a.points)),
        "object_points_median": float(np.median(obj_counts)) if obj_counts else 0.0,
        "objects_dense_fraction": float(np.mean([n >= DENSE_POINTS for n in obj_counts])) if obj_counts else 0.0,
        "busy_frame_fraction": busy / a.instance_masks.shape[0],
        "closeups": closeups,
        "closeups_cropped": cropped,
        "errors": kinds,
    }


def run(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    presets = list(dict.fromkeys(["tiny", preset]))
    rows = []
    for name in presets:
        for seed in seeds:
            path = work_dir / f"{name}_{seed}.zarr"
            if path.exists():
                shutil.rmtree(path)
            cpu, wall = time.process_time(), time.perf_counter()
            scene = make_scene(name, seed)
            write_scene(path, scene, overwrite=True, pictures=True)
            seconds = time.perf_counter() - wall
            frames = scene.arrays.rgb.shape[0]
            rows.append(
                {
                    "preset": name,
                    "seed": seed,
                    "frames": frames,
                    "size": [scene.arrays.rgb.shape[2], scene.arrays.rgb.shape[1]],
                    "seconds": round(seconds, 3),
                    "seconds_per_frame": round(seconds / frames, 4),
                    "cpu_seconds": round(time.process_time() - cpu, 3),
                    "steps": {k: round(v, 3) for k, v in scene.timings.items()},
                    **_content(scene),
                }
            )
            shutil.rmtree(path, ignore_errors=True)
    summary = {}
    for name in presets:
        mine = [r for r in rows if r["preset"] == name]
        summary[name] = {
            "seconds_mean": round(float(np.mean([r["seconds"] for r in mine])), 3),
            "seconds_max": round(float(np.max([r["seconds"] for r in mine])), 3),
            "seconds_per_frame_mean": round(float(np.mean([r["seconds_per_frame"] for r in mine])), 4),
            "cpu_seconds_mean": round(float(np.mean([r["cpu_seconds"] for r in mine])), 3),
        }
    aims = {}
    if "standard" in summary:
        aims["standard_seconds"] = {
            "aim": AIM_STANDARD_SECONDS,
            "measured_max": summary["standard"]["seconds_max"],
            "met": summary["standard"]["seconds_max"] <= AIM_STANDARD_SECONDS,
        }
    return {"runs": rows, "summary": summary, "aims": aims}


def table(result: dict[str, Any]) -> str:
    lines = [
        "| preset | seed | frames | s | s/frame | cpu s | render s | objects | points | dense objs | busy frames | cropped close-ups |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result["runs"]:
        lines.append(
            f"| {r['preset']} | {r['seed']} | {r['frames']} | {r['seconds']:.1f} | {r['seconds_per_frame']:.3f} | "
            f"{r['cpu_seconds']:.1f} | {r['steps'].get('frames_wall', 0):.1f} | {r['objects']} | {r['points']} | "
            f"{r['objects_dense_fraction']:.2f} | {r['busy_frame_fraction']:.2f} | "
            f"{r['closeups_cropped']}/{r['closeups']} |"
        )
    for name, s in result["summary"].items():
        lines.append(
            f"{name}: mean {s['seconds_mean']:.1f} s, max {s['seconds_max']:.1f} s, {s['seconds_per_frame_mean']:.3f} s/frame"
        )
    for key, a in result.get("aims", {}).items():
        lines.append(
            f"aim {key}: <= {a['aim']} s, measured max {a['measured_max']:.1f} s -> {'met' if a['met'] else 'MISSED'}"
        )
    return "\n".join(lines)
