"""The Prefect side of the pipeline benchmark (`rescene bench pipeline`, rescene_core/bench/pipeline.py):
starting Prefect's embedded API, and running the ``rescene`` flow."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from prefect import flow
from prefect.states import State

from flows.scene import run_flow
from rescene_core.bench import pipeline as suite


@flow(name="rescene-bench-warmup")
def warmup() -> int:
    """An empty flow: its first run starts Prefect's embedded API."""
    return 0


class PrefectHarness:
    """``rescene_core.bench.pipeline.Harness`` over Prefect: the ``rescene`` flow on the thread runner."""

    def start(self) -> None:
        os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
        warmup()

    def run(self, capture: Path, run_dir: Path) -> State:
        return run_flow(capture, run_dir)


def bench_pipeline(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    """The pipeline suite with the Prefect harness (see rescene_core/bench/pipeline.py)."""
    return suite.run(seeds, preset, work_dir, harness=PrefectHarness())
