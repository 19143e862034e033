"""Suite `pipeline`: the cost of the Prefect harness around the stages (seconds cold, cached, library).

The measurement drives the ``rescene`` flow, so it lives with the flows (``flows/bench.py``); this
module only registers it as a suite. The library itself never imports Prefect: the import below
happens when the suite runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def run(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    from flows.bench import bench_pipeline

    return bench_pipeline(seeds, preset, work_dir)


def table(result: dict[str, Any]) -> str:
    from flows.bench import table as render

    return render(result)
