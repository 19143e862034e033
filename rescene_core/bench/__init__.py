"""Benchmark suites (`rescene bench SUITE`): each measures one stage on synthetic captures.

A suite module defines ``run(seeds: list[int], preset: str, work_dir: Path) -> dict`` returning a
JSON-serialisable result, and ``table(result: dict) -> str`` rendering it for the terminal. A suite whose
``run`` also takes ``held_out`` (the sim and assembly suites) measures a second seed set, the held-out
seeds, and reports it in its own block beside the development seeds (``seed_sets``), never pooled with them.
"""

from __future__ import annotations

import importlib
import inspect
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
    "scale": "rescene_core.bench.scale",
}
"""Suite name -> module. A suite whose module is not there yet is listed but reports so when run."""


def machine_info() -> dict[str, object]:
    return {"python": platform.python_version(), "cpus": os.cpu_count(), "machine": platform.machine()}


SEED_SETS = ("development", "held_out")
"""The seed sets a suite with held-out seeds reports apart: ``development``, the seeds development decisions
are made on (``--seeds``, 0-4 by default), and ``held_out`` (``--held-out``), reported as they come."""


def seed_sets(seeds: list[int], held_out: list[int] | None) -> dict[str, list[int]]:
    """``{"development": seeds, "held_out": held_out}``, the held-out set left out when none is given.

    ValueError when a seed is in both sets: a held-out figure that shares scenes with the development one
    is not held out."""
    shared = sorted(set(seeds) & set(held_out or ()))
    if shared:
        raise ValueError(f"seeds {format_seeds(shared)} are both development and held-out seeds")
    return {"development": list(seeds), **({"held_out": list(held_out)} if held_out else {})}


def format_seeds(seeds: list[int]) -> str:
    """[0, 1, 2, 3, 4] -> '0-4'; [3, 7, 8, 9] -> '3,7-9' (the form ``--seeds`` reads)."""
    runs: list[list[int]] = []
    for seed in seeds:
        if runs and seed == runs[-1][-1] + 1:
            runs[-1].append(seed)
        else:
            runs.append([seed])
    return ",".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)


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

    options: passed on to the suite's ``run`` (the pipeline suite takes the orchestration ``harness``; the
    sim and assembly suites ``held_out`` seeds, the sim suite ``shake``); ValueError naming an option the
    suite does not take, before anything runs."""
    if name not in SUITES:
        raise SuiteUnavailable(f"unknown suite {name!r}; suites: {', '.join(SUITES)}")
    module = importlib.import_module(SUITES[name])
    takes = inspect.signature(module.run).parameters
    if unknown := [k for k in options if k not in takes]:
        raise ValueError(f"the {name} suite does not take {', '.join(unknown)}")
    out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    result = module.run(seeds=seeds, preset=preset, work_dir=out_dir / f"{name}_work", **options)
    result = {
        "suite": name,
        "preset": preset,
        "seeds": seeds,
        **({"held_out": options["held_out"]} if "held_out" in options else {}),
        "machine": machine_info(),
        "wall_seconds": round(time.perf_counter() - start, 3),
        **result,
    }
    path = write_json_atomic(out_dir / f"{name}.json", result)
    return SuiteRun(result, path, module.table(result))
