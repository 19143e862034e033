"""Suite `pipeline`: the cost of the orchestration harness around the stages.

Per seed, on a synthetic capture:
- ``seconds_api_start``: starting the orchestrator (Prefect's embedded API and an empty flow; once per
  process; a deployment has its server running already, so it is reported apart from the flow runs);
- ``seconds_cold``: the whole ``rescene`` flow into a fresh run directory;
- ``seconds_cached``: the same flow again, same inputs (every task is served from its cache);
- ``seconds_fresh_dir``: the flow into a second, fresh run directory (no Prefect result to serve) with the
  user cache the cold run filled (rescene_core/usercache.py): the CoACD decompositions and the generated
  assets are loaded, not computed again, as when a split is reprocessed or a scene run again elsewhere;
- ``seconds_library``: the same stages called in this process (``rescene_core.pipeline.run_pipeline``:
  no orchestration, no cache, no run log);
- ``overhead_ratio`` = cold / library; per-stage seconds of both (flow: summed task execution times
  from the run log; library: summed call times).

The cold flow run and the library run each start from an empty user cache of their own (``RESCENE_CACHE_DIR``
set to a fresh folder under the work directory for the run), so both decompose and generate everything and
their ratio compares like with like.

The library does not know the orchestrator: the flow is driven through a ``Harness`` that the command
line passes in (``flows/bench.py:PrefectHarness``).
"""

from __future__ import annotations

import os
import shutil
import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from rescene_core.capture.synth import write_synth
from rescene_core.paths import RunPaths
from rescene_core.pipeline import run_pipeline
from rescene_core.runlog import read_messages

AIMS = {"overhead_ratio": 1.20, "cached_fraction": 0.05, "seconds_cold": 120.0}


class FlowOutcome(Protocol):
    """The final state of one flow run, as the benchmark reads it."""

    @property
    def name(self) -> str | None: ...

    @property
    def message(self) -> str | None: ...


class Harness(Protocol):
    """How the benchmark drives the orchestrated pipeline."""

    def start(self) -> None:
        """Start the orchestrator (an API server, an empty flow run): timed as ``seconds_api_start``."""

    def run(self, capture: Path, run_dir: Path) -> FlowOutcome:
        """Run the whole pipeline on ``capture`` into ``run_dir``; returns its final state."""


@contextmanager
def _user_cache(path: Path) -> Iterator[Path]:
    """``RESCENE_CACHE_DIR`` set to ``path`` for the block."""
    before = os.environ.get("RESCENE_CACHE_DIR")
    os.environ["RESCENE_CACHE_DIR"] = str(path)
    try:
        yield path
    finally:
        if before is None:
            os.environ.pop("RESCENE_CACHE_DIR", None)
        else:
            os.environ["RESCENE_CACHE_DIR"] = before


def _capture(work_dir: Path, preset: str, seed: int) -> Path:

    path = work_dir / f"{preset}_seed{seed}.zarr"
    if not path.exists():
        write_synth(path, preset, seed)
    return path


def flow_stage_seconds(run_dir: Path) -> tuple[dict[str, float], dict[str, float]]:
    """Per stage, from the run log: (summed task execution seconds, wall span first start -> last end).

    Tasks of one stage run concurrently in the thread pool, so the summed time counts contention; the
    span is the stage's wall-clock share of the run."""

    seconds: dict[str, float] = defaultdict(float)
    first: dict[str, int] = {}
    last: dict[str, int] = {}
    for _, t, msg in read_messages(RunPaths(run_dir).run_log, topics=["/task/events"]):
        stage = msg["stage"]
        if msg.get("event") == "start":
            first[stage] = min(first.get(stage, t), t)
        elif msg.get("event") == "end":
            seconds[stage] += float(msg["seconds"])
            last[stage] = max(last.get(stage, t), t)
    span = {k: (last[k] - first[k]) / 1e9 for k in last if k in first}
    return dict(seconds), span


def run(seeds: list[int], preset: str, work_dir: Path, harness: Harness | None = None) -> dict[str, Any]:
    """Run the benchmark for every seed; returns the JSON result (see the module docstring)."""
    if harness is None:
        raise ValueError("the pipeline suite measures the orchestrated flow: run it as `rescene bench pipeline`")
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    harness.start()
    api_start = time.perf_counter() - start

    runs: list[dict[str, Any]] = []
    for seed in seeds:
        capture = _capture(work_dir, preset, seed)
        run_dir = work_dir / f"run_{preset}_seed{seed}"
        fresh_dir = work_dir / f"run_{preset}_seed{seed}_fresh"
        flow_cache, library_cache = work_dir / f"cache_flow_seed{seed}", work_dir / f"cache_library_seed{seed}"
        for path in (run_dir, fresh_dir, flow_cache, library_cache):
            shutil.rmtree(path, ignore_errors=True)
        load_before = os.getloadavg()[0]
        with _user_cache(flow_cache):
            start = time.perf_counter()
            state = harness.run(capture, run_dir)
            cold = time.perf_counter() - start
            start = time.perf_counter()
            cached_state = harness.run(capture, run_dir)
            cached = time.perf_counter() - start
            load_fresh = os.getloadavg()[0]
            start = time.perf_counter()
            fresh_state = harness.run(capture, fresh_dir)
            fresh = time.perf_counter() - start
        load_library = os.getloadavg()[0]
        with _user_cache(library_cache):
            start = time.perf_counter()
            library_stages = run_pipeline(capture).seconds
            library = time.perf_counter() - start
        flow_stages, flow_spans = flow_stage_seconds(run_dir)
        fresh_stages, _ = flow_stage_seconds(fresh_dir)
        runs.append(
            {
                "seed": seed,
                "state_cold": state.name,
                "state_cached": cached_state.name,
                "message": state.message,
                "seconds_cold": round(cold, 3),
                "seconds_cached": round(cached, 3),
                "state_fresh_dir": fresh_state.name,
                "seconds_fresh_dir": round(fresh, 3),
                "fresh_dir_fraction": round(fresh / cold, 4) if cold > 0 else None,
                "stage_seconds_fresh_dir": {k: round(v, 3) for k, v in sorted(fresh_stages.items())},
                "seconds_library": round(library, 3),
                "overhead_ratio": round(cold / library, 3) if library > 0 else None,
                "cached_fraction": round(cached / cold, 4) if cold > 0 else None,
                "stage_seconds_flow": {k: round(v, 3) for k, v in sorted(flow_stages.items())},
                "stage_span_flow": {k: round(v, 3) for k, v in sorted(flow_spans.items())},
                "stage_seconds_library": {str(k): round(v, 3) for k, v in sorted(library_stages.items())},
                "load_average_before": round(load_before, 2),
                "load_average_fresh_dir": round(load_fresh, 2),
                "load_average_library": round(load_library, 2),
            }
        )

    def mean(key: str) -> float | None:
        vals = [r[key] for r in runs if r[key] is not None]
        return round(float(np.mean(vals)), 3) if vals else None

    summary = {
        k: mean(k)
        for k in (
            "seconds_cold",
            "seconds_cached",
            "seconds_fresh_dir",
            "seconds_library",
            "overhead_ratio",
            "cached_fraction",
            "fresh_dir_fraction",
        )
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
    for r in result["runs"]:
        if "seconds_fresh_dir" in r:
            lines.append(
                f"seed {r['seed']}: a fresh run directory with the user cache warm {r['seconds_fresh_dir']:.1f} s "
                f"({r['fresh_dir_fraction']:.3f} x cold, load {r['load_average_fresh_dir']:.1f}, {r['state_fresh_dir']})"
            )
    lines.append(
        "per stage (s, first seed): flow wall span, flow summed task time (concurrent), library call time, "
        "flow summed task time in a fresh run directory (user cache warm)"
    )
    first = result["runs"][0]
    for stage in sorted(set(first["stage_seconds_flow"]) | set(first["stage_seconds_library"])):
        lines.append(
            f"  {stage:14s} {first['stage_span_flow'].get(stage, 0.0):8.2f} "
            f"{first['stage_seconds_flow'].get(stage, 0.0):8.2f} {first['stage_seconds_library'].get(stage, 0.0):8.2f} "
            f"{first.get('stage_seconds_fresh_dir', {}).get(stage, 0.0):8.2f}"
        )
    met = result["aims_met"]
    lines.append(
        "aims: "
        + ", ".join(f"{k} {'met' if v else 'MISSED'}" for k, v in met.items())
        + f" (overhead <= {AIMS['overhead_ratio']}, cached <= {AIMS['cached_fraction']} x cold, cold <= {AIMS['seconds_cold']} s)"
    )
    return "\n".join(lines)
