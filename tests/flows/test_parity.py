"""The Prefect flow and the in-process pipeline run the same stage description: on the same capture they
write the same files with the same contents (besides what only the flow keeps: its manifest, config,
instance table, Prefect results and the run log, whose messages carry times).

Contents are compared byte for byte, except that JSON files are compared with their wall-clock timings
left out and the run directory's own path read as ``RUN``, and the evaluation's reports (report.md,
report.html: renderings of eval/metrics.json, timings and the run's path included) by their presence."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rescene_core.config import RunConfig
from rescene_core.pipeline import run_pipeline

FLOW_ONLY = ("manifest.json", "config.yaml", "instances.parquet")
"""Files the flow writes about itself (run-directory.md); the pipeline has no orchestration to record."""
SKIPPED_DIRS = (".prefect", "logs", ".faults")
"""Prefect's persisted results, the run log (its messages carry wall-clock times), fault counters."""


RENDERED = ("eval/report.md", "eval/report.html")


def _timeless(value: Any, root: str) -> Any:
    """``value`` without wall-clock timings (keys ``seconds``, ``seconds_*``, ``timings_s``), ``root`` as RUN."""
    if isinstance(value, dict):
        return {
            k: _timeless(v, root)
            for k, v in value.items()
            if not (k == "seconds" or k.startswith("seconds_") or k == "timings_s")
        }
    if isinstance(value, list):
        return [_timeless(v, root) for v in value]
    if isinstance(value, str):
        return value.replace(root, "RUN")
    return value


def _files(root: Path) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if not path.is_file() or rel.parts[0] in SKIPPED_DIRS or str(rel) in FLOW_ONLY:
            continue
        if str(rel) in RENDERED:
            out[str(rel)] = "rendered"
        elif path.suffix == ".json":
            out[str(rel)] = _timeless(json.loads(path.read_text()), str(root.resolve()))
        else:
            out[str(rel)] = path.read_bytes()
    return out


def test_flow_and_pipeline_write_the_same_files(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import run_flow

    state = run_flow(box_capture_path, tmp_path / "flow", RunConfig())
    assert state.is_completed(), state.message
    run_pipeline(box_capture_path, RunConfig(), tmp_path / "pipeline")
    flow, pipeline = _files(tmp_path / "flow"), _files(tmp_path / "pipeline")
    assert sorted(flow) == sorted(pipeline)
    for name in ("sim/simcheck.json", "eval/metrics.json", "layout.json", "scene/scene.json", "shell.json"):
        assert name in flow, name
    assert [name for name in flow if flow[name] != pipeline[name]] == []
    assert (tmp_path / "flow" / "logs" / "run.mcap").exists() and (tmp_path / "pipeline" / "logs" / "run.mcap").exists()
