"""What a flow run records about itself: the config it ran with, the state of each task run, and at the
end the merged run log, ``manifest.json``, the instance table and the Prefect artifacts.

The content of the manifest and the report is decided in ``rescene_core.manifest``; this module reads
Prefect futures and states and publishes the artifacts.
"""

from __future__ import annotations

from typing import Any

import yaml
from prefect.artifacts import create_markdown_artifact, create_table_artifact
from prefect.futures import PrefectFuture

from rescene_core.config import RunConfig
from rescene_core.io import write_bytes_atomic, write_json_atomic
from rescene_core.manifest import InstanceRow, StageRow, build_manifest, render_report, write_instance_table
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Missing, Ref, Stage
from rescene_core.runlog import merge_segments
from rescene_core.stages.dag import code_versions

_EXC_PREFIX = "Task run encountered an exception "


def failure_reason(future: PrefectFuture, default: str) -> str:
    """Why a task run did not complete, without Prefect's exception prefix."""
    return (future.state.message or default).replace(_EXC_PREFIX, "")


def write_run_config(run: RunPaths, config: RunConfig) -> None:
    """``config.yaml``: the RunConfig of the run, in the format ``rescene run --config`` reads."""
    write_bytes_atomic(run.config, yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False).encode())


def state_row(stage: Stage, item: int | None, future: PrefectFuture[Any]) -> StageRow:
    """One task run as the flow saw it (a stage row of the manifest and of /flow/tasks)."""
    st = future.state
    return StageRow(
        stage=stage,
        item=item,
        state=st.name or st.type.value,
        cached=st.name == "Cached",
        message=None if st.is_completed() else st.message,
    )


def instance_outcome(
    instance: int, futures: list[tuple[Stage, PrefectFuture]]
) -> tuple[Ref | None, Missing | None, bool]:
    """(final reference, Missing, failed) of one instance from its stage futures (asset, registration).

    failed = a task raised (after retries) rather than returning an explicit Missing.
    """
    for stage, fut in futures:
        st = fut.state
        if st.is_completed():
            continue
        if st.is_failed() or st.is_crashed() or st.is_cancelled():
            reason = failure_reason(fut, f"{stage} task ended {st.name}")
            return None, Missing(InstanceId(instance), stage, reason), True
    ref: Ref = futures[-1][1].result()
    return ref, ref.missing, False


def finish_run(
    run: RunPaths,
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
) -> dict[str, Any]:
    """Merge the run log, write manifest.json and instances.parquet, publish the report and the
    instance table as Prefect artifacts; returns the manifest."""
    merge_segments(run.root)
    manifest = build_manifest(
        capture=capture,
        scene_id=scene_id,
        config=config,
        flow_run_id=flow_run_id,
        started=started,
        stage_rows=stage_rows,
        rows=rows,
        missing=missing,
        failed=failed,
        state=state,
        message=message,
        stage_versions=code_versions(),
    )
    write_json_atomic(run.manifest, manifest)
    write_instance_table(run.instance_table, rows)
    create_markdown_artifact(render_report(manifest), key="rescene-report", description="ReScene run report")
    if rows:
        create_table_artifact(
            [r.to_json() for r in rows], key="rescene-instances", description="instances: view, asset, registration"
        )
    return manifest
