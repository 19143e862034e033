"""The pipeline benchmark (`rescene bench pipeline`): the cost of the Prefect harness around the stages.

Per seed, on a synthetic capture:
- ``seconds_api_start``: starting Prefect's embedded API and running an empty flow (once per process;
  a deployment has its server running already, so it is reported apart from the flow runs);
- ``seconds_cold``: the whole ``rescene`` flow into a fresh run directory;
- ``seconds_cached``: the same flow again, same inputs (every task is served from its cache);
- ``seconds_library``: the same stage functions called directly in sequence, no Prefect, no files;
- ``overhead_ratio`` = cold / library; per-stage seconds of both (flow: summed task execution times
  from the run log; library: summed call times).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

AIMS = {"overhead_ratio": 1.20, "cached_fraction": 0.05, "seconds_cold": 120.0}


def _capture(work_dir: Path, preset: str, seed: int) -> Path:
    from rescene_core.capture.synth import write_synth

    path = work_dir / f"{preset}_seed{seed}.zarr"
    if not path.exists():
        write_synth(path, preset, seed)
    return path


def library_run(capture_path: Path) -> dict[str, float]:
    """Call every stage directly (default config), in the flow's order; returns seconds per stage."""
    from rescene_core.capture import open_capture
    from rescene_core.capture.ground_truth import read_ground_truth
    from rescene_core.config import RunConfig
    from rescene_core.evaluation import evaluate_run
    from rescene_core.export import ExportConfig, ExportObject, export_scene
    from rescene_core.records import InstanceId, Missing
    from tasks import stages

    config = RunConfig()
    seconds: dict[str, float] = defaultdict(float)

    def timed(stage, fn, *args):
        start = time.perf_counter()
        out = fn(*args)
        seconds[stage] += time.perf_counter() - start
        return out

    cap = open_capture(capture_path)
    shell = timed("shell", stages.estimate_shell, cap, config.shell)
    ids = [int(i.id) for i in cap.object_instances]
    views = timed("view", stages.select_views, cap, config.hierview, ids)
    objects, missing = {}, set()
    for i in ids:
        view = views.get(i)
        asset = view if isinstance(view, Missing) else timed("asset", stages.generate_asset, cap, view, config.assets)
        pose = asset
        if not isinstance(asset, Missing):
            pose = timed("registration", stages.register, asset, cap.point_cloud(i), config.registration)
        if isinstance(pose, Missing) or view is None:
            missing.add(i)
            continue
        objects[InstanceId(i)] = stages.assembly_object(
            i, cap.instance(i).label, asset.vertices, asset.faces, pose.world_from_asset
        )
    keyframes = timed("keyframes", stages.select_keyframes, cap, config.keyframes)
    predictor = stages.make_predictor(config.scenegraph)
    preds = [
        timed("relations", stages.predict_frame, cap, int(t), shell, config.scenegraph, predictor)
        for t in keyframes.frames
    ]
    graph = timed("fusion", stages.fuse, preds, cap, shell, config.scenegraph, missing)
    layout = timed("attachment", stages.attach, objects, graph, shell, config.attachment) if objects else None
    with tempfile.TemporaryDirectory(prefix="rescene-bench-") as tmp:
        export_objects = [
            ExportObject(
                int(i), o.label, o.vertices, o.faces,
                layout.world_from_asset.get(i, o.world_from_asset) if layout else o.world_from_asset,
                o.world_from_asset,
            )
            for i, o in objects.items()
        ]  # fmt: skip
        missing_records = [Missing(InstanceId(i), "library", "not placed") for i in sorted(missing)]
        timed(
            "export", export_scene, Path(tmp) / "scene", export_objects, shell, graph, missing_records, ExportConfig()
        )
        if read_ground_truth(cap) is not None:
            timed("evaluation", evaluate_run, tmp, capture_path)
    return dict(seconds)


def _flow_stage_seconds(run_dir: Path) -> tuple[dict[str, float], dict[str, float]]:
    """Per stage, from the run log: (summed task execution seconds, wall span first start -> last end).

    Tasks of one stage run concurrently in the thread pool, so the summed time counts contention; the
    span is the stage's wall-clock share of the run."""
    from rescene_core.runlog import read_messages

    seconds: dict[str, float] = defaultdict(float)
    first: dict[str, int] = {}
    last: dict[str, int] = {}
    for _, t, msg in read_messages(run_dir / "logs" / "run.mcap", topics=["/task/events"]):
        stage = msg["stage"]
        if msg.get("event") == "start":
            first[stage] = min(first.get(stage, t), t)
        elif msg.get("event") == "end":
            seconds[stage] += float(msg["seconds"])
            last[stage] = max(last.get(stage, t), t)
    span = {k: (last[k] - first[k]) / 1e9 for k in last if k in first}
    return dict(seconds), span


def bench_pipeline(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    """Run the benchmark for every seed; returns the JSON result (see the module docstring)."""
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    from prefect import flow

    from flows.scene import run_flow

    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)

    @flow(name="rescene-bench-warmup")
    def warmup() -> int:
        return 0

    start = time.perf_counter()
    warmup()
    api_start = time.perf_counter() - start

    runs = []
    for seed in seeds:
        capture = _capture(work_dir, preset, seed)
        run_dir = work_dir / f"run_{preset}_seed{seed}"
        shutil.rmtree(run_dir, ignore_errors=True)
        load_before = os.getloadavg()[0]
        start = time.perf_counter()
        state = run_flow(capture, run_dir)
        cold = time.perf_counter() - start
        start = time.perf_counter()
        cached_state = run_flow(capture, run_dir)
        cached = time.perf_counter() - start
        start = time.perf_counter()
        library_stages = library_run(capture)
        library = time.perf_counter() - start
        flow_stages, flow_spans = _flow_stage_seconds(run_dir)
        runs.append(
            {
                "seed": seed,
                "state_cold": state.name,
                "state_cached": cached_state.name,
                "message": state.message,
                "seconds_cold": round(cold, 3),
                "seconds_cached": round(cached, 3),
                "seconds_library": round(library, 3),
                "overhead_ratio": round(cold / library, 3) if library > 0 else None,
                "cached_fraction": round(cached / cold, 4) if cold > 0 else None,
                "stage_seconds_flow": {k: round(v, 3) for k, v in sorted(flow_stages.items())},
                "stage_span_flow": {k: round(v, 3) for k, v in sorted(flow_spans.items())},
                "stage_seconds_library": {k: round(v, 3) for k, v in sorted(library_stages.items())},
                "load_average_before": round(load_before, 2),
            }
        )

    def mean(key: str) -> float | None:
        vals = [r[key] for r in runs if r[key] is not None]
        return round(float(np.mean(vals)), 3) if vals else None

    summary = {
        k: mean(k) for k in ("seconds_cold", "seconds_cached", "seconds_library", "overhead_ratio", "cached_fraction")
    }
    aims_met = {
        "overhead_ratio": summary["overhead_ratio"] is not None and summary["overhead_ratio"] <= AIMS["overhead_ratio"],
        "seconds_cached": summary["cached_fraction"] is not None
        and summary["cached_fraction"] <= AIMS["cached_fraction"],
        "seconds_cold": summary["seconds_cold"] is not None and summary["seconds_cold"] <= AIMS["seconds_cold"],
    }
    return {
        "seconds_api_start": round(api_start, 3),
        "runner": "thread",
        "summary": summary,
        "aims": AIMS,
        "aims_met": aims_met,
        "runs": runs,
    }


def table(result: dict[str, Any]) -> str:
    """Terminal rendering of a pipeline benchmark result."""
    lines = [
        f"pipeline benchmark ({result['preset']}, seeds {result['seeds']}); embedded API start "
        f"{result['seconds_api_start']:.1f} s (not in the flow times)",
        f"{'seed':>4} {'cold s':>8} {'cached s':>9} {'library s':>10} {'overhead':>9} {'cached/cold':>12} {'load':>5}  state",
    ]
    for r in result["runs"]:
        lines.append(
            f"{r['seed']:>4} {r['seconds_cold']:>8.1f} {r['seconds_cached']:>9.2f} {r['seconds_library']:>10.1f} "
            f"{r['overhead_ratio']:>9.3f} {r['cached_fraction']:>12.4f} {r['load_average_before']:>5.1f}  {r['state_cold']}"
        )
    s = result["summary"]
    lines.append(
        f"mean {s['seconds_cold']:>8.1f} {s['seconds_cached']:>9.2f} {s['seconds_library']:>10.1f} "
        f"{s['overhead_ratio']:>9.3f} {s['cached_fraction']:>12.4f}"
    )
    lines.append("per stage (s, first seed): flow wall span, flow summed task time (concurrent), library call time")
    first = result["runs"][0]
    for stage in sorted(set(first["stage_seconds_flow"]) | set(first["stage_seconds_library"])):
        lines.append(
            f"  {stage:14s} {first['stage_span_flow'].get(stage, 0.0):8.2f} "
            f"{first['stage_seconds_flow'].get(stage, 0.0):8.2f} {first['stage_seconds_library'].get(stage, 0.0):8.2f}"
        )
    met = result["aims_met"]
    lines.append(
        "aims: "
        + ", ".join(f"{k} {'met' if v else 'MISSED'}" for k, v in met.items())
        + f" (overhead <= {AIMS['overhead_ratio']}, cached <= {AIMS['cached_fraction']} x cold, cold <= {AIMS['seconds_cold']} s)"
    )
    return "\n".join(lines)
