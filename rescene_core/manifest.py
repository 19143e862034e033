"""The run manifest (``RUN/manifest.json``), the instance table (``RUN/instances.parquet``) and the run
report, built from what a pipeline run recorded. Plain values in, plain values out: the orchestration
layer gathers the task states, this module decides what the manifest says.

A ``StageRow`` is one task run as the orchestrator saw it; an ``InstanceRow`` is one line of the instance
table. Both are frozen records; ``to_json`` gives the manifest's and the run log's form.
"""

from __future__ import annotations

import datetime as dt
import io
import subprocess
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from rescene_core.config import RunConfig
from rescene_core.io import write_bytes_atomic
from rescene_core.records import Missing, Ref, Stage

FORMAT = "rescene-run"
VERSION = 1

INSTANCE_COLUMNS = ("instance", "label", "view", "asset", "registration", "missing_stage", "missing_reason")
"""Columns of the instance table, in order."""

REPO_ROOT = Path(__file__).resolve().parents[1]


def now_iso() -> str:
    """The current UTC time as ISO 8601 (the manifest's ``started`` / ``finished``)."""
    return dt.datetime.now(dt.UTC).isoformat()


def git_describe(root: str | Path = REPO_ROOT) -> str | None:
    """``git describe --always --dirty`` of the source tree, or None outside a git checkout."""
    try:
        out = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty"], capture_output=True, text=True, timeout=5
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


@dataclass(frozen=True)
class StageRow:
    """One task run as the orchestrator saw it. item: the instance or key frame (None for a scene-level
    stage); state: Prefect's state name; cached: served from the cache; message: why it did not complete."""

    stage: Stage
    item: int | None
    state: str
    cached: bool
    seconds: float | None = None
    message: str | None = None

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class InstanceRow:
    """One line of the instance table: the chosen view's frame (or "missing" / "-"), the asset's face count
    (or "missing" / "-"), registration "ok" / "missing", and the stage and reason of a Missing instance."""

    instance: int
    label: str
    view: int | str = "-"
    asset: str = "-"
    registration: str = "ok"
    missing_stage: str = ""
    missing_reason: str = ""

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    def with_asset(self, asset: Ref) -> InstanceRow:
        """The row with its asset cell filled in: the face count, or "missing"."""
        return replace(self, asset=f"{asset.numbers.get('faces', 0)} faces" if asset.ok else "missing")


def instance_row(instance: int, label: str, view: Ref | None, missing: Missing | None) -> InstanceRow:
    """The instance's row: chosen view frame (or "missing"), registration ok/missing, missing stage and reason.

    ``asset`` starts as "-"; the orchestrator fills it in (``with_asset``) once the asset task has finished."""
    shown: int | str = "-"
    if view is not None:
        shown = view.numbers.get("frame", "-") if view.ok else "missing"
    return InstanceRow(
        instance=instance,
        label=label,
        view=shown,
        registration="missing" if missing else "ok",
        missing_stage=missing.stage.value if missing else "",
        missing_reason=missing.reason if missing else "",
    )


def final_message(failures: Iterable[Missing], frame_failures: list[str], scene_error: str | None) -> str | None:
    """The failure message of a run (None when it completed): failed instances grouped by stage and
    reason, key frames left out of fusion, and the first scene-level error."""
    failures = sorted(failures, key=lambda m: m.instance)
    parts = []
    if failures:
        ids = ", ".join(str(int(m.instance)) for m in failures)
        by_reason: dict[tuple[str, str], list[int]] = {}
        for m in failures:
            by_reason.setdefault((m.stage.value, m.reason), []).append(int(m.instance))
        detail = "; ".join(f"{stage}: {reason} ({', '.join(map(str, i))})" for (stage, reason), i in by_reason.items())
        parts.append(f"instances failed: {ids} -- {detail}")
    if frame_failures:
        parts.append(f"left out of fusion: {', '.join(frame_failures)}")
    if scene_error:
        parts.append(f"scene stage failed: {scene_error}")
    return " | ".join(parts) or None


def stage_counts(stage_rows: Iterable[StageRow]) -> dict[str, dict[str, int]]:
    """Per stage, task runs by final state: ``cached`` for cache hits, else the state name in lower case."""
    stages: dict[str, dict[str, int]] = {}
    for r in stage_rows:
        key = "cached" if r.cached else r.state.lower()
        stages.setdefault(str(r.stage), {}).setdefault(key, 0)
        stages[str(r.stage)][key] += 1
    return stages


def build_manifest(
    *,
    capture: Ref,
    scene_id: str,
    config: RunConfig,
    flow_run_id: str,
    started: str,
    stage_rows: list[StageRow],
    rows: list[InstanceRow],
    missing: list[Missing],
    failed: list[int],
    state: str,
    message: str | None,
    stage_versions: Mapping[Stage, str],
) -> dict[str, Any]:
    """The manifest of a run (docs/run-directory.md lists its fields). ``stage_versions``: the code
    version of each stage (source hashes), next to the tree's ``git describe``."""
    return {
        "format": FORMAT,
        "version": VERSION,
        "flow_run_id": flow_run_id,
        "state": state,
        "message": message,
        "started": started,
        "finished": now_iso(),
        "capture": {
            "path": capture.path,
            "sha256": capture.sha256,
            "scene_id": scene_id,
            "verification": capture.detail.get("verification"),
            "rehashed_files": capture.detail.get("rehashed_files"),
        },
        "config": config.model_dump(mode="json"),
        "config_hashes": {s: config.section_hash(s) for s in RunConfig.model_fields},
        "code_version": {"git": git_describe(), "stages": {str(k): v for k, v in stage_versions.items()}},
        "stages": stage_counts(stage_rows),
        "instances": [r.to_json() for r in rows],
        "missing": [m.to_json() for m in missing],
        "failed_instances": failed,
    }


def write_instance_table(path: str | Path, rows: list[InstanceRow]) -> Path:
    """The instance table as Parquet (every column a string but the instance id), written atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(
        {
            c: pa.array(
                [getattr(r, c) if c == "instance" else str(getattr(r, c)) for r in rows],
                pa.int64() if c == "instance" else pa.string(),
            )
            for c in INSTANCE_COLUMNS
        }
    )
    buffer = io.BytesIO()
    pq.write_table(table, buffer)
    return write_bytes_atomic(path, buffer.getvalue())


def render_report(manifest: Mapping[str, Any]) -> str:
    """The run report as markdown: state, capture, per-stage completed/cached/failed counts, missing instances."""
    lines = [
        f"# ReScene run: {manifest['capture']['scene_id']}",
        "",
        f"- state: **{manifest['state']}**" + (f" - {manifest['message']}" if manifest["message"] else ""),
        f"- capture: `{manifest['capture']['path']}` (sha256 {manifest['capture']['sha256'][:12]})",
        f"- instances: {len(manifest['instances'])}, missing: {len(manifest['missing'])}",
        "",
        "| stage | " + " | ".join(["completed", "cached", "failed", "other"]) + " |",
        "|---|---|---|---|---|",
    ]
    for stage, counts in manifest["stages"].items():
        other = sum(v for k, v in counts.items() if k not in ("completed", "cached", "failed"))
        lines.append(
            f"| {stage} | {counts.get('completed', 0)} | {counts.get('cached', 0)} | {counts.get('failed', 0)} | {other} |"
        )
    if manifest["missing"]:
        lines += ["", "## Missing instances", ""]
        lines += [f"- {m['instance']} ({m['stage']}): {m['reason']}" for m in manifest["missing"]]
    return "\n".join(lines)
