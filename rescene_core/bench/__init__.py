"""Benchmark suites (`rescene bench SUITE`): each measures one stage on synthetic captures.

A suite module defines ``run(seeds: list[int], preset: str, work_dir: Path) -> dict`` returning a
JSON-serialisable result, and ``table(result: dict) -> str`` rendering it for the terminal.
"""

from __future__ import annotations

import importlib
import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rescene_core.io import write_json_atomic

SUITES: dict[str, str] = {
    "synth": "rescene_core.bench.synth",
    "hierview": "rescene_core.bench.hierview",
    "registration": "rescene_core.bench.registration",
    "scenegraph": "rescene_core.bench.scenegraph",
    "assembly": "rescene_core.bench.assembly",
    "pipeline": "rescene_core.bench.pipeline",
    "sim": "rescene_core.bench.sim",
    "paper": "rescene_core.bench.paper",
    "import": "rescene_core.bench.importers",
}
"""Suite name -> module. A suite whose module is not there yet is listed but reports so when run."""


def machine_info() -> dict[str, object]:
    return {"python": platform.python_version(), "cpus": os.cpu_count(), "machine": platform.machine()}


class SuiteUnavailable(RuntimeError):
    """No suite of that name (the message lists the suites)."""


@dataclass(frozen=True)
class SuiteRun:
    """One suite's run: its JSON result, where it was written, and its table for the terminal."""

    result: dict[str, Any]
    path: Path
    table: str


def run_suite(name: str, out_dir: Path, seeds: list[int], preset: str, **options: object) -> SuiteRun:
    """Run one suite and write ``out_dir/<name>.json``; SuiteUnavailable for an unknown suite name.

    options: passed on to the suite's ``run`` (the pipeline suite takes the orchestration ``harness``)."""
    if name not in SUITES:
        raise SuiteUnavailable(f"unknown suite {name!r}; suites: {', '.join(SUITES)}")
    module = importlib.import_module(SUITES[name])
    out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    result = module.run(seeds=seeds, preset=preset, work_dir=out_dir / f"{name}_work", **options)
    result = {
        "suite": name,
        "preset": preset,
        "seeds": seeds,
        "machine": machine_info(),
        "wall_seconds": round(time.perf_counter() - start, 3),
        **result,
    }
    path = write_json_atomic(out_dir / f"{name}.json", result)
    return SuiteRun(result, path, module.table(result))
