"""Suite `scale`: how the import and the run grow with the number of frames.

The same synthetic room (``--preset``, ``--seeds``: the layout and furniture are drawn before the cameras,
so only the camera walk changes with the frame count) captured with each of ``--frames`` frames
(default 120, 600, 1200), then per frame count:

- ``import``: the capture written out as a ScanNet reader export (colour at twice the depth size, as
  ScanNet's 1296x968 against 640x480, uint16 depth, poses, the 2D instance and label PNGs) and imported
  back with ``rescene_core.capture.importers.scannet.import_scannet`` in a child process: wall seconds,
  frames per second, the importer's own steps (read, align, segment, points, write) and peak RSS;
- ``run``: the whole pipeline on the synthetic capture (``rescene_core.pipeline.run_pipeline``, every
  stage, exports, physics check and evaluation included) in a child process with an empty user cache (a
  cold run): wall seconds per stage and peak RSS per stage, and the CoACD workers' peak apart;
- the slope of each step and stage: the least-squares slope of log(seconds) on log(frames) over the
  frame counts (1 = linear, 2 = quadratic), so ``frames x 5 -> seconds x 5^slope``, of the wall seconds
  and of the CPU seconds (every thread of the child, sampled with the resident set; the CoACD workers'
  apart). The linear aim is judged on CPU seconds: on a shared machine the wall seconds carry the load,
  which can change by half between two rows of one suite run.

Peak RSS per step or stage: the child samples its own resident set (``/proc/self/statm``) every
``SAMPLE_S`` and takes the largest sample inside the step's time window (the run's windows come from its
run log's stage start and end events, the import's from its report's step timings); the whole process's
peak is its ``VmHWM`` (``peak_rss_self``), which a sample can miss between two reads, never exceed.

The machine's load average (1 min) is read before each measurement and printed with every figure; figures
taken under load are slower than on a quiet machine, not comparable across loads.

One room is enough to read growth from, and each frame count costs minutes (the 1,200-frame capture alone
takes minutes to render), so only the first of ``--seeds`` is measured (``make bench`` passes five).
"""

from __future__ import annotations

import json
import math
import os
import resource
import shutil
import subprocess
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.io import read_json, write_json_atomic

DEFAULT_FRAMES = (120, 600, 1200)
SAMPLE_S = 0.05
"""Interval of the resident-set samples (s)."""
AIMS = {"import_fps": 10.0, "run_seconds_at_600": 300.0, "peak_rss_gb": 6.0, "max_slope": 1.1}
"""The issue's aims: import >= 10 frames/s, a 600-frame run <= 300 s, peak RSS <= 6 GB for the import and
the run; a step or stage grows at most linearly in frames (slope <= 1.1: the 0.1 allows for the timing
noise of a shared machine between two runs minutes apart)."""
PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


class _RssSampler:
    """A thread sampling this process's resident set and CPU time: [(time_ns, bytes, cpu seconds)]."""

    def __init__(self) -> None:
        self.samples: list[tuple[int, int, float]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                with open("/proc/self/statm") as f:
                    rss = int(f.read().split()[1]) * PAGE
            except OSError:  # not Linux: only getrusage's peak is reported
                return
            self.samples.append((time.time_ns(), rss, time.process_time()))
            self._stop.wait(SAMPLE_S)

    def __enter__(self) -> _RssSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def peak(self, start_ns: int, end_ns: int) -> int | None:
        """Largest sample in [start_ns, end_ns] (bytes), None when no sample fell in it."""
        inside = [rss for t, rss, _ in self.samples if start_ns <= t <= end_ns]
        return max(inside) if inside else None

    def cpu(self, start_ns: int, end_ns: int) -> float | None:
        """CPU seconds (every thread of this process, user and system) spent in [start_ns, end_ns], from the
        samples nearest inside it; None when fewer than two samples fell in it."""
        inside = [c for t, _, c in self.samples if start_ns <= t <= end_ns]
        return round(inside[-1] - inside[0], 3) if len(inside) >= 2 else None


def _maxrss_bytes(who: int) -> int:
    return int(resource.getrusage(who).ru_maxrss) * 1024  # Linux reports kilobytes


def peak_rss_self() -> int:
    """This process's own peak resident set (bytes): ``VmHWM`` of ``/proc/self/status``, the high-water mark
    of its address space. ``getrusage``'s ``ru_maxrss`` is not that: a child started with vfork + exec (as
    ``subprocess`` starts one) keeps its parent's peak, so a suite that wrote a 600-frame capture reported
    the parent's 3.73 GB for every child after it. Outside Linux, ``ru_maxrss``."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024  # kB
    except OSError:
        pass
    return _maxrss_bytes(resource.RUSAGE_SELF)


def _gb(n: int | None) -> float | None:
    return None if n is None else round(n / 1e9, 3)


def child_import(src: Path, out: Path, result: Path) -> None:
    """Import the ScanNet export ``src`` into ``out``; write seconds, steps and RSS to ``result``."""
    from rescene_core.capture.importers.common import ImportOptions
    from rescene_core.capture.importers.scannet import import_scannet

    with _RssSampler() as rss:
        start_ns = time.time_ns()
        report = import_scannet(src, out, ImportOptions(overwrite=True))
        end_ns = time.time_ns()
    steps: dict[str, dict[str, Any]] = {}
    at = start_ns
    for step, sec in report["timings_s"].items():
        if step == "total":
            continue
        stop = at + int(sec * 1e9)
        steps[step] = {"seconds": sec, "cpu_seconds": rss.cpu(at, stop), "peak_rss_gb": _gb(rss.peak(at, stop))}
        at = stop
    write_json_atomic(
        result,
        {
            "seconds": round((end_ns - start_ns) / 1e9, 3),
            "cpu_seconds": round(time.process_time(), 3),
            "frames": report["frames"]["kept"],
            "fps": report["throughput_fps"],
            "steps": steps,
            "peak_rss_gb": _gb(peak_rss_self()),
        },
    )


def child_run(capture: Path, run_dir: Path, result: Path) -> None:
    """Run the whole pipeline on ``capture`` into ``run_dir``; write per-stage seconds and RSS to ``result``."""
    from rescene_core.paths import RunPaths
    from rescene_core.pipeline import run_pipeline
    from rescene_core.runlog import read_messages

    with _RssSampler() as rss:
        start_ns = time.time_ns()
        done = run_pipeline(capture, out_dir=run_dir)
        end_ns = time.time_ns()
    first: dict[str, int] = {}
    last: dict[str, int] = {}
    for _, t, msg in read_messages(RunPaths(run_dir).run_log, topics=["/task/events"]):
        stage = str(msg["stage"])
        if msg.get("event") == "start":
            first[stage] = min(first.get(stage, t), t)
        elif msg.get("event") in ("end", "error"):
            last[stage] = max(last.get(stage, t), t)
    stages = {
        str(stage): {
            "seconds": round(sec, 3),
            "cpu_seconds": rss.cpu(first[str(stage)], last[str(stage)]) if str(stage) in last else None,
            "peak_rss_gb": _gb(rss.peak(first[str(stage)], last[str(stage)])) if str(stage) in last else None,
        }
        for stage, sec in done.seconds.items()
    }
    metrics = done.metrics or {}
    write_json_atomic(
        result,
        {
            "seconds": round((end_ns - start_ns) / 1e9, 3),
            "cpu_seconds": round(time.process_time(), 3),
            "children_cpu_seconds": round(
                resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
                + resource.getrusage(resource.RUSAGE_CHILDREN).ru_stime,
                3,
            ),
            "stages": stages,
            "peak_rss_gb": _gb(peak_rss_self()),
            "children_peak_rss_gb": _gb(_maxrss_bytes(resource.RUSAGE_CHILDREN)),
            "missing": len(done.missing),
            "metrics": {k: metrics[k] for k in sorted(metrics) if isinstance(metrics[k], int | float)},
        },
    )


def _child(kind: str, args: list[Path], result: Path, env: dict[str, str]) -> dict[str, Any]:
    """Run ``child_<kind>`` in a fresh interpreter (its peak RSS is its own); returns its result."""
    result.unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "rescene_core.bench.scale", kind, *map(str, args), str(result)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if done.returncode != 0 or not result.exists():
        tail = "\n".join((done.stderr or done.stdout).strip().splitlines()[-15:])
        raise RuntimeError(f"the {kind} child failed (exit {done.returncode}):\n{tail}")
    return dict(read_json(result))


def slope(frames: list[int], seconds: list[float]) -> float | None:
    """Least-squares slope of log(seconds) on log(frames); None with fewer than two usable points."""
    pts = [(math.log(f), math.log(s)) for f, s in zip(frames, seconds, strict=True) if f > 0 and s > 0]
    if len(pts) < 2 or len({x for x, _ in pts}) < 2:
        return None
    x, y = np.array(pts).T
    return round(float(np.polyfit(x, y, 1)[0]), 3)


def _load() -> float:
    return round(os.getloadavg()[0], 2)


PARTS = ("import", "run")


def run(
    seeds: list[int],
    preset: str,
    work_dir: Path,
    frames: list[int] | None = None,
    parts: tuple[str, ...] = PARTS,
) -> dict[str, Any]:
    """Measure the import and the run at each frame count (see the module doc); the JSON result.

    parts: which of 'import' and 'run' to measure (both by default; the run is most of the suite's time)."""
    if not parts or set(parts) - set(PARTS):
        raise ValueError(f"parts {parts!r}: choose from {PARTS}")
    from rescene_core.capture import open_capture
    from rescene_core.capture.importers.layouts import write_scannet
    from rescene_core.capture.synth import write_synth

    counts = sorted(set(frames or DEFAULT_FRAMES))
    if not counts or min(counts) < 2:
        raise ValueError(f"--frames {counts}: give frame counts of at least 2, e.g. --frames 120,600,1200")
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    for seed in seeds[:1]:
        for n in counts:
            capture = work_dir / f"{preset}_seed{seed}_f{n}.zarr"
            row: dict[str, Any] = {"seed": seed, "frames": n}
            if not capture.exists():
                row["load_synth"] = _load()
                t = time.perf_counter()
                write_synth(capture, preset, seed, frames=n)
                row["seconds_synth"] = round(time.perf_counter() - t, 3)
            cap = open_capture(capture, validate=False)
            row["objects"] = len(cap.object_instances)
            row["image_size"] = list(cap.image_size)
            scan = work_dir / f"scannet_{preset}_seed{seed}_f{n}"
            if "import" in parts and not (scan / "scannetv2-labels.combined.tsv").exists():
                shutil.rmtree(scan, ignore_errors=True)  # written only when the import is measured (minutes)
                write_scannet(cap, scan)
            del cap
            cache = work_dir / f"cache_{preset}_seed{seed}_f{n}"
            shutil.rmtree(cache, ignore_errors=True)  # a cold run: nothing decomposed or generated yet
            env = os.environ | {"RESCENE_CACHE_DIR": str(cache)}
            if "import" in parts:
                row["load_import"] = _load()
                imported = work_dir / f"imported_{preset}_seed{seed}_f{n}.zarr"
                row["import"] = _child("import", [scan, imported], work_dir / f"import_f{n}.json", env)
                shutil.rmtree(imported, ignore_errors=True)
            if "run" in parts:
                run_dir = work_dir / f"run_{preset}_seed{seed}_f{n}"
                shutil.rmtree(run_dir, ignore_errors=True)
                row["load_run"] = _load()
                row["run"] = _child("run", [capture, run_dir], work_dir / f"run_f{n}.json", env)
            row["load_after"] = _load()
            rows.append(row)
            write_json_atomic(work_dir / "partial.json", {"rows": rows})  # a long suite keeps what it measured
    return {"frames": counts, "seeds_measured": seeds[:1], "aims": AIMS, "rows": rows, **_summary(rows)}


def _summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Slopes per import step and run stage (first seed), of wall seconds and of CPU seconds, and the aims."""
    seed0 = [r for r in rows if r["seed"] == rows[0]["seed"]] if rows else []
    frames = [r["frames"] for r in seed0]
    wall: dict[str, list[float]] = defaultdict(list)
    cpu: dict[str, list[float]] = defaultdict(list)

    def add(name: str, item: dict[str, Any]) -> None:
        wall[name].append(item["seconds"])
        if item.get("cpu_seconds") is not None:
            cpu[name].append(item["cpu_seconds"])

    for r in seed0:
        for part, inner in (("import", "steps"), ("run", "stages")):
            if part in r:
                add(f"{part} total", r[part])
                for name, v in r[part][inner].items():
                    add(f"{part} {name}", v)
    slopes = {k: slope(frames, v) if len(v) == len(frames) else None for k, v in wall.items()}
    cpu_slopes = {k: slope(frames, v) if len(v) == len(frames) else None for k, v in cpu.items()}
    imports = [r["import"] for r in rows if "import" in r]
    runs = [r["run"] for r in rows if "run" in r]
    at600 = [r["run"] for r in rows if r["frames"] == 600 and "run" in r]
    # the linear aim is read on CPU seconds where they were measured: wall seconds on a shared machine carry
    # the load, which changed by a factor of 1.5 between two rows of one suite run
    judged = {k: cpu_slopes.get(k, slopes[k]) for k in slopes}
    aims_met = {
        "import_fps": all(i["fps"] >= AIMS["import_fps"] for i in imports) if imports else None,
        "run_seconds_at_600": all(r["seconds"] <= AIMS["run_seconds_at_600"] for r in at600) if at600 else None,
        "peak_rss_gb": all(x["peak_rss_gb"] <= AIMS["peak_rss_gb"] for x in imports + runs) if rows else None,
        "at_most_linear": all(v is None or v <= AIMS["max_slope"] for v in judged.values())
        if len(frames) > 1
        else None,
    }
    return {"slopes": slopes, "cpu_slopes": cpu_slopes, "aims_met": aims_met}


def table(result: dict[str, Any]) -> str:
    """Terminal rendering: one block per frame count, then the slopes."""
    lines = [f"scale benchmark ({result['preset']}, seeds {result['seeds']}, frames {result['frames']})"]

    def fmt(v: float | None, spec: str) -> str:
        return "-" if v is None else format(v, spec)

    for r in result["rows"]:
        lines.append(
            f"seed {r['seed']}, {r['frames']} frames {r['image_size'][0]}x{r['image_size'][1]}, {r['objects']} objects"
        )
        if "import" in r:
            imp = r["import"]
            lines.append(
                f"  import  {imp['seconds']:8.1f} s (CPU {fmt(imp.get('cpu_seconds'), '.1f')} s)  "
                f"{imp['fps']:6.2f} frames/s  peak RSS {imp['peak_rss_gb']:.2f} GB  (load {r['load_import']:.1f})"
            )
            for step, v in imp["steps"].items():
                lines.append(
                    f"    {step:12s} {v['seconds']:8.2f} s  CPU {fmt(v.get('cpu_seconds'), '8.2f')} s  "
                    f"RSS {fmt(v['peak_rss_gb'], '.2f')} GB"
                )
        if "run" in r:
            run_ = r["run"]
            lines.append(
                f"  run     {run_['seconds']:8.1f} s (CPU {fmt(run_.get('cpu_seconds'), '.1f')} s, CoACD workers "
                f"{fmt(run_.get('children_cpu_seconds'), '.1f')} s)  peak RSS {run_['peak_rss_gb']:.2f} GB "
                f"(CoACD workers {run_['children_peak_rss_gb']:.2f} GB)  (load {r['load_run']:.1f} -> {r['load_after']:.1f})"
            )
            for stage, v in run_["stages"].items():
                lines.append(
                    f"    {stage:12s} {v['seconds']:8.2f} s  CPU {fmt(v.get('cpu_seconds'), '8.2f')} s  "
                    f"RSS {fmt(v['peak_rss_gb'], '.2f')} GB"
                )
    lines.append("slope of log(seconds) on log(frames) (1 = linear): wall, CPU")
    for k, v in result["slopes"].items():
        lines.append(f"  {k:22s} {fmt(v, '6.2f')} {fmt(result.get('cpu_slopes', {}).get(k), '6.2f')}")
    met = result["aims_met"]
    lines.append(
        "aims: "
        + ", ".join(f"{k} {'not measured' if v is None else 'met' if v else 'MISSED'}" for k, v in met.items())
        + f" (import >= {AIMS['import_fps']:g} frames/s, 600-frame run <= {AIMS['run_seconds_at_600']:g} s, "
        f"peak RSS <= {AIMS['peak_rss_gb']:g} GB, CPU-time slope <= {AIMS['max_slope']:g})"
    )
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    """``python -m rescene_core.bench.scale import SRC OUT RESULT`` or ``run CAPTURE RUN_DIR RESULT``."""
    kind, *paths = argv
    if kind == "import" and len(paths) == 3:
        child_import(*map(Path, paths))
    elif kind == "run" and len(paths) == 3:
        child_run(*map(Path, paths))
    else:
        print(json.dumps({"usage": "import SRC OUT RESULT | run CAPTURE RUN_DIR RESULT"}), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
