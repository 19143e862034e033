"""The split flow ``rescene-split``: (re)process every capture of a dataset split.

Each capture not yet done runs as a run of the ``rescene/scene`` deployment (``run_deployment``), so
every worker polling the pool shares the work (``deployment=None`` runs it as a subflow in this
process instead). A scene is done, and skipped, when its run directory holds a Completed manifest of
the same capture content (identity stamp), the same config (section hashes) and the same code version
(stage source hashes); anything else runs again, so rerunning a split after a crash redoes only what
is not done (and the task cache makes the finished instances of a half-done scene cost nothing).

Split file (docs/orchestration.md): one scene a line, ``CAPTURE [NAME]``: the capture path (relative
paths are relative to the split file) and optionally the run directory's name under ``out_root``
(default: the capture's file stem); blank lines and ``#`` comments are ignored.

A scene whose capture is missing or changed in place fails with the reason and the others run; a scene
not final after ``timeout_s`` is recorded as TimedOut. The summary (``<split>_summary.parquet`` and
``.md`` under ``out_root``) lists every scene: done, skipped, failed, timed out.
"""

from __future__ import annotations

import io
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from uuid import UUID

import pyarrow as pa
import pyarrow.parquet as pq
from prefect import flow, get_run_logger
from prefect.artifacts import create_markdown_artifact
from prefect.client.orchestration import get_client
from prefect.client.schemas.objects import FlowRun
from prefect.deployments import run_deployment
from prefect.states import Completed, Failed, State

from rescene_core.capture.identity import capture_identity
from rescene_core.config import RunConfig
from rescene_core.io import read_json, write_bytes_atomic
from rescene_core.paths import RunPaths
from rescene_core.stages.dag import code_versions


class SplitFileError(ValueError):
    """A split file that cannot be read: the message names the file, the line and the fix."""


@dataclass(frozen=True)
class SplitEntry:
    """One scene of a split: its capture and the name of its run directory under ``out_root``."""

    capture: Path
    name: str


def read_split_entries(split_file: str | Path) -> list[SplitEntry]:
    """The scenes listed in ``split_file`` (capture paths resolved against its folder)."""
    split_file = Path(split_file)
    if not split_file.exists():
        raise SplitFileError(
            f"split file {split_file} does not exist; write one capture path a line (docs/orchestration.md)"
        )
    out: list[SplitEntry] = []
    names: dict[str, int] = {}
    for n, raw in enumerate(split_file.read_text().splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.split()
        if len(fields) > 2:
            raise SplitFileError(f"{split_file}:{n}: {len(fields)} fields; write CAPTURE [NAME] (no spaces in paths)")
        p = Path(fields[0])
        capture = p if p.is_absolute() else (split_file.parent / p).resolve()
        name = fields[1] if len(fields) == 2 else capture.stem
        if name in names:
            raise SplitFileError(
                f"{split_file}:{n}: run name {name!r} is already used on line {names[name]}; give one a NAME"
            )
        names[name] = n
        out.append(SplitEntry(capture, name))
    return out


def read_split(split_file: str | Path) -> list[Path]:
    """The capture paths listed in ``split_file`` (resolved against its folder)."""
    return [e.capture for e in read_split_entries(split_file)]


def done_reason(run_dir: Path, capture_sha256: str, config: RunConfig) -> str | None:
    """Why ``run_dir`` does not hold a finished run of this capture content, config and code (None: it does)."""
    manifest_path = RunPaths(run_dir).manifest
    if not manifest_path.exists():
        return "no manifest"
    try:
        m = read_json(manifest_path)
    except (OSError, ValueError) as exc:  # cut short or not JSON: whatever wrote it did not finish
        return f"manifest unreadable ({type(exc).__name__})"
    if not isinstance(m, dict):
        return "manifest unreadable (not a JSON object)"
    if m.get("state") != "Completed":
        return f"last run {m.get('state')}"
    if m.get("capture", {}).get("sha256") != capture_sha256:
        return "capture content changed"
    hashes = {s: config.section_hash(s) for s in RunConfig.model_fields}
    if m.get("config_hashes") != hashes:
        return "config changed"
    versions = {str(s): v for s, v in code_versions().items()}
    if (m.get("code_version") or {}).get("stages") != versions:
        return "code changed"
    return None


def scene_done(run_dir: Path, capture: Path, config: RunConfig | None = None) -> bool:
    """Whether ``run_dir`` holds a Completed run of ``capture``'s content with ``config`` and this code."""
    try:
        sha = capture_identity(capture).content_hash
    except Exception:  # noqa: BLE001 - missing, changed in place or unreadable: not done
        return False
    return done_reason(run_dir, sha, config or RunConfig()) is None


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
"""Columns of the split summary: one row per scene of the split, in split order."""


def _row(
    entry: SplitEntry, run_dir: Path, state: str, skipped: bool, flow_run_id: str | None, message: str | None, ran=True
):
    """One summary row; the instance counts come from the run's manifest when the scene ran (``ran``)."""
    path = RunPaths(run_dir).manifest
    manifest = read_json(path) if ran and path.exists() else {}
    return {
        "scene": entry.name,
        "capture": str(entry.capture),
        "run_dir": str(run_dir),
        "state": state,
        "skipped": skipped,
        "flow_run_id": flow_run_id,
        "instances": len(manifest.get("instances", [])),
        "missing": len(manifest.get("missing", [])),
        "message": message,
    }


def summary_markdown(split_name: str, rows: list[dict[str, Any]]) -> str:
    """The split summary as a Markdown table, with the counts on top."""
    counts = summary_counts(rows)
    lines = [
        f"# Split {split_name}",
        "",
        f"{counts['scenes']} scenes: {counts['completed']} completed ({counts['skipped']} skipped as done), "
        f"{counts['failed']} failed, {counts['timed_out']} timed out",
        "",
        "| scene | state | skipped | instances | missing | message |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        message = (r["message"] or "").replace("|", "/").replace("\n", " ")
        lines.append(
            f"| {r['scene']} | {r['state']} | {'yes' if r['skipped'] else 'no'} | {r['instances']} | "
            f"{r['missing']} | {message} |"
        )
    return "\n".join(lines) + "\n"


def summary_counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    return {
        "scenes": len(rows),
        "skipped": sum(bool(r["skipped"]) for r in rows),
        "completed": sum(r["state"] == "Completed" for r in rows),
        "failed": sum(r["state"] not in ("Completed", "TimedOut") for r in rows),
        "timed_out": sum(r["state"] == "TimedOut" for r in rows),
    }


def write_summary(out: Path, split_name: str, rows: list[dict[str, Any]]) -> tuple[Path, Path]:
    """``out/<split>_summary.parquet`` and ``.md``, written atomically."""
    buffer = io.BytesIO()
    pq.write_table(pa.Table.from_pylist(rows, schema=SUMMARY_SCHEMA), buffer)
    parquet = write_bytes_atomic(out / f"{split_name}_summary.parquet", buffer.getvalue())
    markdown = write_bytes_atomic(out / f"{split_name}_summary.md", summary_markdown(split_name, rows).encode())
    return Path(parquet), Path(markdown)


def _wait_final(flow_run_ids: list[UUID], poll_interval_s: float, deadline: float) -> dict[UUID, State]:
    """Poll the API until every flow run is final or the deadline (monotonic) passes; returns the
    final states (runs not final by then are absent)."""
    final: dict[UUID, State] = {}
    with get_client(sync_client=True) as client:
        while True:
            for run_id in flow_run_ids:
                if run_id in final:
                    continue
                state = client.read_flow_run(run_id).state
                if state is not None and state.is_final():
                    final[run_id] = state
            if len(final) == len(flow_run_ids) or time.monotonic() >= deadline:
                return final
            time.sleep(min(poll_interval_s, max(deadline - time.monotonic(), 0.0)))


@flow(name="rescene-split", description="Run every capture of a split file through rescene/scene.")
def rescene_split(
    split_file: str,
    out_root: str = "runs",
    deployment: str | None = "rescene/scene",
    config: RunConfig | None = None,
    poll_interval_s: float = 5.0,
    timeout_s: float = 6 * 3600.0,
):
    """Process the scenes of ``split_file`` into ``out_root/<name>``; writes the summary next to them and
    returns the counts. Ends Failed (after every scene was tried) when a scene failed or timed out."""
    logger = get_run_logger()
    config = config or RunConfig()
    out = Path(out_root).resolve()
    out.mkdir(parents=True, exist_ok=True)
    split_name = Path(split_file).stem
    entries = read_split_entries(split_file)
    rows: dict[str, dict[str, Any]] = {}
    pending: list[tuple[SplitEntry, Path, Any]] = []
    start = time.monotonic()
    for entry in entries:
        run_dir = out / entry.name
        try:
            if not entry.capture.exists():
                raise FileNotFoundError(entry.capture)
            sha = capture_identity(entry.capture).content_hash
        except FileNotFoundError:
            rows[entry.name] = _row(entry, run_dir, "Failed", False, None, f"capture not found: {entry.capture}", False)
            logger.error("%s: capture not found: %s", entry.name, entry.capture)
            continue
        except Exception as exc:  # noqa: BLE001 - changed in place, or not a capture store: this scene fails
            rows[entry.name] = _row(entry, run_dir, "Failed", False, None, f"{type(exc).__name__}: {exc}", False)
            logger.error("%s: %s", entry.name, exc)
            continue
        reason = done_reason(run_dir, sha, config)
        if reason is None:
            logger.info("skip %s: already done in %s", entry.name, run_dir)
            rows[entry.name] = _row(entry, run_dir, "Completed", True, None, "already done")
            continue
        logger.info("run %s (%s)", entry.name, reason)
        params: dict[str, Any] = {"capture": str(entry.capture), "run_dir": str(run_dir)}
        params["config"] = config.model_dump(mode="json")
        if deployment is None:  # in this process, one scene after the other
            from flows.scene import rescene

            local = rescene(capture=str(entry.capture), run_dir=str(run_dir), config=config, return_state=True)
            rows[entry.name] = _row(entry, run_dir, local.name or local.type.value, False, None, local.message)
            continue
        try:
            flow_run = run_deployment(name=deployment, parameters=params, timeout=0, as_subflow=True)
        except Exception as exc:  # noqa: BLE001 - the API refused or failed this submission: the others still run
            message = f"could not submit a {deployment} run: {type(exc).__name__}: {exc}"
            rows[entry.name] = _row(entry, run_dir, "Failed", False, None, message, False)
            logger.error("%s: %s", entry.name, message)
            continue
        assert isinstance(flow_run, FlowRun)  # a sync flow gets the flow run, not the async variant's coroutine
        logger.info("submitted %s as flow run %s", entry.name, flow_run.id)
        pending.append((entry, run_dir, flow_run))
    if pending:
        final = _wait_final([f.id for _, _, f in pending], poll_interval_s, start + timeout_s)
        for entry, run_dir, flow_run in pending:
            state = final.get(flow_run.id)
            if state is None:
                message = f"not final after {timeout_s:.0f} s (flow run {flow_run.id} goes on; rerun the split later)"
                rows[entry.name] = _row(entry, run_dir, "TimedOut", False, str(flow_run.id), message)
            else:
                rows[entry.name] = _row(
                    entry, run_dir, state.name or state.type.value, False, str(flow_run.id), state.message
                )
    ordered = [rows[e.name] for e in entries]
    parquet, markdown = write_summary(out, split_name, ordered)
    create_markdown_artifact(summary_markdown(split_name, ordered), key="rescene-split-summary")
    counts: dict[str, Any] = {**summary_counts(ordered), "seconds": round(time.monotonic() - start, 1)}
    counts.update(summary=str(parquet), summary_md=str(markdown))
    logger.info("split %s: %s", split_file, counts)
    bad = [r for r in ordered if r["state"] != "Completed"]
    if bad:
        names = ", ".join(f"{r['scene']} ({r['state']}: {r['message']})" for r in bad)
        return Failed(message=f"{len(bad)} of {len(ordered)} scenes not completed: {names}", data=counts)
    return Completed(message=f"{len(ordered)} scenes completed ({counts['skipped']} skipped as done)", data=counts)
