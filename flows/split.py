"""The split flow ``rescene-split``: (re)process every capture of a dataset split.

Each capture not yet done runs as a run of the ``rescene/scene`` deployment (``run_deployment``), so
every worker polling the pool shares the work; scenes whose run directory already holds a Completed
manifest for the same capture are skipped. A Parquet table summarises the split.

Split file: one capture path per line (relative paths are relative to the split file); blank lines and
lines starting with ``#`` are ignored.
"""

from __future__ import annotations

import io
import time
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
from prefect import flow, get_run_logger
from prefect.client.orchestration import get_client
from prefect.deployments import run_deployment

from rescene_core.config import RunConfig
from rescene_core.io import read_json, write_bytes_atomic
from rescene_core.paths import RunPaths


def read_split(split_file: str | Path) -> list[Path]:
    """The capture paths listed in ``split_file`` (resolved against its folder)."""
    split_file = Path(split_file)
    if not split_file.exists():
        raise FileNotFoundError(f"split file {split_file} does not exist")
    out = []
    for line in split_file.read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        p = Path(line)
        out.append(p if p.is_absolute() else (split_file.parent / p).resolve())
    return out


def scene_done(run_dir: Path, capture: Path) -> bool:
    """Whether ``run_dir`` holds a Completed run of ``capture``."""
    manifest = RunPaths(run_dir).manifest
    if not manifest.exists():
        return False
    m = read_json(manifest)
    return m.get("state") == "Completed" and Path(m["capture"]["path"]) == capture.resolve()


SUMMARY_SCHEMA = pa.schema(
    [
        ("scene", pa.string()),
        ("capture", pa.string()),
        ("run_dir", pa.string()),
        ("state", pa.string()),
        ("skipped", pa.bool_()),
        ("flow_run_id", pa.string()),
        ("instances", pa.int32()),
        ("missing", pa.int32()),
        ("message", pa.string()),
    ]
)


def _row(capture: Path, run_dir: Path, state: str, skipped: bool, flow_run_id: str | None, message: str | None):
    path = RunPaths(run_dir).manifest
    manifest = read_json(path) if path.exists() else {}
    return {
        "scene": capture.stem,
        "capture": str(capture),
        "run_dir": str(run_dir),
        "state": state,
        "skipped": skipped,
        "flow_run_id": flow_run_id,
        "instances": len(manifest.get("instances", [])),
        "missing": len(manifest.get("missing", [])),
        "message": message,
    }


def _wait_final(flow_run_id, poll_interval_s: float):
    """Poll the API until the flow run reaches a final state; returns that state."""
    with get_client(sync_client=True) as client:
        while True:
            state = client.read_flow_run(flow_run_id).state
            if state is not None and state.is_final():
                return state
            time.sleep(poll_interval_s)


@flow(name="rescene-split", description="Run every capture of a split file through rescene/scene.")
def rescene_split(
    split_file: str,
    out_root: str = "runs",
    deployment: str = "rescene/scene",
    config: RunConfig | None = None,
    poll_interval_s: float = 5.0,
) -> dict[str, Any]:
    """Process the captures of ``split_file`` into ``out_root/<capture stem>``; writes
    ``out_root/<split name>_summary.parquet`` and returns the counts."""
    logger = get_run_logger()
    out = Path(out_root).resolve()
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    pending = []
    for capture in read_split(split_file):
        run_dir = out / capture.stem
        if scene_done(run_dir, capture):
            logger.info("skip %s: already done in %s", capture.stem, run_dir)
            rows.append(_row(capture, run_dir, "Completed", True, None, "already done"))
            continue
        params = {"capture": str(capture), "run_dir": str(run_dir)}
        if config is not None:
            params["config"] = config.model_dump(mode="json")
        flow_run = run_deployment(name=deployment, parameters=params, timeout=0, as_subflow=True)
        logger.info("submitted %s as flow run %s", capture.stem, flow_run.id)
        pending.append((capture, run_dir, flow_run))
    start = time.perf_counter()
    for capture, run_dir, flow_run in pending:
        state = _wait_final(flow_run.id, poll_interval_s)
        rows.append(
            _row(
                capture,
                run_dir,
                state.name if state else "Unknown",
                False,
                str(flow_run.id),
                state.message if state else None,
            )
        )
    table = pa.Table.from_pylist(rows, schema=SUMMARY_SCHEMA)
    summary_path = out / f"{Path(split_file).stem}_summary.parquet"
    buffer = io.BytesIO()
    pq.write_table(table, buffer)
    write_bytes_atomic(summary_path, buffer.getvalue())
    counts = {
        "scenes": len(rows),
        "skipped": sum(r["skipped"] for r in rows),
        "completed": sum(r["state"] == "Completed" for r in rows),
        "failed": sum(r["state"] not in ("Completed",) for r in rows),
        "seconds_waited": round(time.perf_counter() - start, 1),
        "summary": str(summary_path),
    }
    logger.info("split %s: %s", split_file, counts)
    return counts
