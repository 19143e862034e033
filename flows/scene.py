"""The Prefect flow ``rescene``: one capture -> one run directory. Wiring only; the work is in tasks/.

Order: room shell; per instance ``.map`` over view selection -> asset -> registration; key frames and
per-key-frame relation inference (independent of the instances, so they run alongside them); fan-in
to fusion (which needs the missing instances), attachment, export, and evaluation when the capture has
ground truth. Every task's result is a reference cached on its inputs' content hashes (tasks/common.py).

An instance whose task still fails after its retries is recorded as Missing; the scene is assembled
from the rest and the flow run ends Failed with a message naming the instances, so that retrying the
flow run (``prefect flow-run retry``) re-executes only those instances and the stages after them.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from prefect import flow, get_run_logger, unmapped
from prefect.artifacts import (
    create_markdown_artifact,
    create_progress_artifact,
    create_table_artifact,
    update_progress_artifact,
)
from prefect.context import FlowRunContext
from prefect.futures import PrefectFuture, as_completed, wait
from prefect.states import Completed, Failed, State

from rescene_core.capture import CaptureError, open_capture
from rescene_core.config import RunConfig, load_config
from rescene_core.export import ExportConfig
from rescene_core.io import hash_tree, write_bytes_atomic, write_json_atomic
from rescene_core.records import InstanceId, Missing
from rescene_core.runlog import Segment, merge_segments
from tasks import instance as instance_tasks
from tasks import scene as scene_tasks
from tasks.common import RESULTS_DIR, ref_missing, retry_delays
from tasks.scene import validate_capture
from tasks.stages import STAGE_MODULES, code_version

ProgressListener = Callable[[int, int, dict[str, Any]], None]
PROGRESS_LISTENERS: list[ProgressListener] = []
"""Called in the flow's process as each instance finishes: (done, total, instance row). The demo's
progress bar registers here."""

PROGRESS_INTERVAL_S = 1.0
"""The progress artifact is updated as instances finish, at most once per this many seconds (and at
the end), so a burst of cached instances costs one API call, not one per instance."""


def _bind(task_, results: Path):
    """The task with this run's result storage (cache records live in the run directory)."""
    return task_.with_options(result_storage=results, retry_delay_seconds=retry_delays(task_.retries))


def _git_version() -> str | None:
    root = Path(__file__).resolve().parents[1]
    try:
        out = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty"], capture_output=True, text=True, timeout=5
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def _state_row(stage: str, item: int | None, fut: PrefectFuture) -> dict[str, Any]:
    st = fut.state
    return {
        "stage": stage,
        "item": item,
        "state": st.name or st.type.value,
        "cached": st.name == "Cached",
        "seconds": None,
        "message": None if st.is_completed() else st.message,
    }


_EXC_PREFIX = "Task run encountered an exception "


def _row(instance: int, label: str, view_ref: dict | None, miss: Missing | None) -> dict[str, Any]:
    """The instance's row of the instance table (artifact, manifest, progress listeners)."""
    view = "-"
    if view_ref is not None:
        view = view_ref["numbers"].get("frame", "-") if view_ref["status"] == "ok" else "missing"
    return {
        "instance": instance,
        "label": label,
        "view": view,
        "asset": "-",
        "registration": "missing" if miss else "ok",
        "missing_stage": miss.stage if miss else "",
        "missing_reason": miss.reason if miss else "",
    }


def _outcome(instance: int, futures: list[tuple[str, PrefectFuture]]) -> tuple[dict | None, Missing | None, bool]:
    """(final reference, Missing, failed) of one instance from its stage futures (asset, registration).

    failed = a task raised (after retries) rather than returning an explicit Missing.
    """
    for stage, fut in futures:
        st = fut.state
        if st.is_completed():
            continue
        if st.is_failed() or st.is_crashed() or st.is_cancelled():
            reason = (st.message or f"{stage} task ended {st.name}").replace(_EXC_PREFIX, "")
            return None, Missing(InstanceId(instance), stage, reason), True
    ref = futures[-1][1].result()
    return ref, ref_missing(ref), False


@flow(name="rescene", description="Multi-view capture -> simulation-ready object-level scene (ReScene).")
def rescene(capture: str, run_dir: str, config: RunConfig | None = None) -> dict[str, Any]:
    """Run ReScene on ``capture`` (a capture .zarr) into ``run_dir`` with ``config`` (defaults: the paper)."""
    config = config or RunConfig()
    export_config = ExportConfig()
    logger = get_run_logger()
    run = Path(run_dir).resolve()
    run.mkdir(parents=True, exist_ok=True)
    started = dt.datetime.now(dt.UTC).isoformat()
    flow_ctx = FlowRunContext.get()
    flow_run_id = str(flow_ctx.flow_run.id) if flow_ctx and flow_ctx.flow_run else "local"
    write_bytes_atomic(run / "config.yaml", yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False).encode())
    flow_log = Segment(run, "flow")
    flow_log.log("/flow/events", {"event": "start", "flow_run_id": flow_run_id, "details": {"capture": capture}})

    capture_ref = {"kind": "capture", "path": str(Path(capture).resolve()), "sha256": hash_tree(capture)}
    # validation is cached on the capture's content hash: a bad capture fails here with every problem
    # listed; an unchanged one is not re-read
    validate_capture.with_options(result_storage=run / RESULTS_DIR)(capture_ref)
    cap = open_capture(capture, validate=False)
    ids = [int(i.id) for i in cap.object_instances]
    labels = {int(i.id): i.label for i in cap.object_instances}
    logger.info("capture %s: %d object instances, %d frames", cap.scene_id, len(ids), cap.num_frames)

    results = run / RESULTS_DIR
    t = {name: _bind(getattr(mod, name), results) for mod, name in [
        (scene_tasks, "estimate_shell"), (instance_tasks, "select_views"), (instance_tasks, "generate_asset"),
        (instance_tasks, "register_instance"), (scene_tasks, "select_keyframes"), (scene_tasks, "predict_relations"),
        (scene_tasks, "fuse_graph"), (scene_tasks, "snapshot_registration"), (scene_tasks, "attach_layout"),
        (scene_tasks, "export"), (scene_tasks, "evaluate"),
    ]}  # fmt: skip
    rd, cr = unmapped(str(run)), unmapped(capture_ref)
    rows: list[dict[str, Any]] = []
    stage_rows: list[dict[str, Any]] = []
    failures: list[Missing] = []
    missing: list[Missing] = []
    frame_failures: list[str] = []
    scene_error: str | None = None
    progress_id = create_progress_artifact(0.0, description=f"instances of {cap.scene_id} finished")

    try:
        shell_f = t["estimate_shell"].submit(str(run), capture_ref, config.shell)
        views_f = t["select_views"].submit(str(run), capture_ref, ids, config.hierview)
        keyframes_f = t["select_keyframes"].submit(str(run), capture_ref, config.keyframes)
        wait([views_f])
        stage_rows.append(_state_row("view", None, views_f))
        if views_f.state.is_completed():
            view_refs = views_f.result()
        else:  # view selection itself failed: every instance is missing at this stage
            reason = (views_f.state.message or "view selection failed").replace(_EXC_PREFIX, "")
            failures += [Missing(InstanceId(i), "view", reason) for i in ids]
            view_refs = []
        assets = t["generate_asset"].map(rd, cr, view_refs, unmapped(config.assets))
        poses = t["register_instance"].map(rd, cr, assets, unmapped(config.registration))
        frames = keyframes_f.result()["frames"]
        preds = t["predict_relations"].map(rd, cr, unmapped(shell_f), frames, unmapped(config.scenegraph))

        # fan-in of the instances, reporting progress as each one finishes
        index = {fut: k for k, fut in enumerate(poses)}
        by_instance: dict[int, dict[str, Any]] = {
            m.instance: {"ref": None, "asset": None, "row": _row(m.instance, labels[m.instance], None, m)}
            for m in failures
        }
        last_update = time.monotonic()
        for done, fut in enumerate(as_completed(list(poses)), start=1):
            k = index[fut]
            i = ids[k]
            per_stage = [("asset", assets[k]), ("registration", poses[k])]
            wait([f for _, f in per_stage])
            ref, miss, failed = _outcome(i, per_stage)
            row = _row(i, labels[i], view_refs[k], miss)
            if assets[k].state.is_completed():
                aref = assets[k].result()
                row["asset"] = f"{aref['numbers'].get('faces', 0)} faces" if aref["status"] == "ok" else "missing"
            if miss is not None:
                (failures if failed else missing).append(miss)
            by_instance[i] = {"ref": ref, "asset": assets[k] if not failed else None, "row": row}
            for stage, f in per_stage:
                stage_rows.append(_state_row(stage, i, f))
            now = time.monotonic()
            if done == len(view_refs) or now - last_update >= PROGRESS_INTERVAL_S:
                update_progress_artifact(progress_id, 100.0 * done / max(len(ids), 1))
                last_update = now
            for listener in PROGRESS_LISTENERS:
                listener(done, len(ids), row)
        if not view_refs:
            update_progress_artifact(progress_id, 100.0)
        rows = [by_instance[i]["row"] for i in ids]
        ok_poses = [by_instance[i]["ref"] for i in ids if by_instance[i]["ref"] is not None]
        ok_assets = [by_instance[i]["asset"].result() for i in ids if by_instance[i]["asset"] is not None]
        all_missing = [m.to_json() for m in sorted(failures + missing, key=lambda m: m.instance)]

        snapshot_f = t["snapshot_registration"].submit(
            str(run), capture_ref, shell_f, ok_assets, ok_poses, export_config
        )
        wait(list(preds))
        ok_preds = []
        for frame, fut in zip(frames, preds):
            stage_rows.append(_state_row("relations", frame, fut))
            if fut.state.is_completed():
                ok_preds.append(fut.result())
            else:
                logger.warning("key frame %d left out of fusion: %s", frame, fut.state.message)
                frame_failures.append(f"key frame {frame} ({fut.state.message})")
        graph_f = t["fuse_graph"].submit(str(run), capture_ref, shell_f, ok_preds, all_missing, config.scenegraph)
        layout_f = t["attach_layout"].submit(
            str(run), capture_ref, shell_f, graph_f, ok_assets, ok_poses, config.attachment, export_config
        )
        scene_f = t["export"].submit(
            str(run), capture_ref, shell_f, graph_f, layout_f, ok_assets, ok_poses, all_missing, export_config
        )
        scene_level = [("shell", shell_f), ("keyframes", keyframes_f), ("snapshot", snapshot_f)]
        scene_level += [("fusion", graph_f), ("attachment", layout_f), ("export", scene_f)]
        if cap.has_gt:
            scene_level.append(("evaluation", t["evaluate"].submit(str(run), capture_ref, scene_f)))
        wait([f for _, f in scene_level])
        for stage, fut in scene_level:
            stage_rows.append(_state_row(stage, None, fut))
            if not fut.state.is_completed() and scene_error is None and fut.state.name != "NotReady":
                scene_error = f"{stage}: {fut.state.message}"
    except Exception as err:  # a scene-level stage could not even be scheduled or returned nothing usable
        scene_error = scene_error or f"{type(err).__name__}: {err}"
        raise
    finally:
        instance_failures = sorted(int(m.instance) for m in failures)
        message = _final_message(failures, frame_failures, scene_error)
        state_name = "Failed" if message else "Completed"
        for row in stage_rows:
            flow_log.log("/flow/tasks", row)
        missing_all = sorted(failures + missing, key=lambda m: (int(m.instance), m.stage))
        flow_log.log(
            "/flow/events",
            {
                "event": "end",
                "flow_run_id": flow_run_id,
                "state": state_name,
                "message": message or "",
                "missing": [m.to_json() for m in missing_all],
            },
        )
        flow_log.close()
        merge_segments(run)
        manifest = _manifest(
            run, capture_ref, cap.scene_id, config, flow_run_id, started, stage_rows, rows, missing_all,
            instance_failures, state_name, message,
        )  # fmt: skip
        write_json_atomic(run / "manifest.json", manifest)
        _write_table(run / "instances.parquet", rows)
        _artifacts(manifest, rows)

    summary = {
        "run_dir": str(run),
        "state": state_name,
        "instances": len(ids),
        "missing": [m.to_json() for m in missing_all],
        "failed_instances": instance_failures,
    }
    if message:
        return Failed(message=message, data=summary)
    return Completed(message=f"{len(ids) - len(missing_all)} of {len(ids)} instances placed", data=summary)


def _final_message(failures: list[Missing], frame_failures: list[str], scene_error: str | None) -> str | None:
    parts = []
    if failures:
        ids = ", ".join(str(int(m.instance)) for m in sorted(failures, key=lambda m: m.instance))
        by_reason: dict[tuple[str, str], list[int]] = {}
        for m in sorted(failures, key=lambda m: m.instance):
            by_reason.setdefault((m.stage, m.reason), []).append(int(m.instance))
        detail = "; ".join(f"{stage}: {reason} ({', '.join(map(str, i))})" for (stage, reason), i in by_reason.items())
        parts.append(f"instances failed: {ids} -- {detail}")
    if frame_failures:
        parts.append(f"left out of fusion: {', '.join(frame_failures)}")
    if scene_error:
        parts.append(f"scene stage failed: {scene_error}")
    return " | ".join(parts) or None


def _manifest(
    run, capture_ref, scene_id, config, flow_run_id, started, stage_rows, rows, missing, failed, state, message
):
    stages: dict[str, dict[str, int]] = {}
    for r in stage_rows:
        key = "cached" if r["cached"] else r["state"].lower()
        stages.setdefault(r["stage"], {}).setdefault(key, 0)
        stages[r["stage"]][key] += 1
    sections = list(RunConfig.model_fields)
    return {
        "format": "rescene-run",
        "version": 1,
        "flow_run_id": flow_run_id,
        "state": state,
        "message": message,
        "started": started,
        "finished": dt.datetime.now(dt.UTC).isoformat(),
        "capture": {"path": capture_ref["path"], "sha256": capture_ref["sha256"], "scene_id": scene_id},
        "config": config.model_dump(mode="json"),
        "config_hashes": {s: config.section_hash(s) for s in sections},
        "code_version": {"git": _git_version(), "stages": {s: code_version(s) for s in STAGE_MODULES}},
        "stages": stages,
        "instances": rows,
        "missing": [m.to_json() for m in missing],
        "failed_instances": failed,
    }


def _write_table(path: Path, rows: list[dict[str, Any]]) -> None:
    """The instance table as Parquet (all columns as strings but the instance id), written atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns = ["instance", "label", "view", "asset", "registration", "missing_stage", "missing_reason"]
    table = pa.table(
        {
            c: pa.array(
                [r[c] if c == "instance" else str(r[c]) for r in rows], pa.int64() if c == "instance" else pa.string()
            )
            for c in columns
        }
    )
    tmp = path.with_name(f".{path.name}.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def _artifacts(manifest: dict[str, Any], rows: list[dict[str, Any]]) -> None:
    """The run report (markdown) and the table of instances, as Prefect artifacts."""
    lines = [
        f"# ReScene run: {manifest['capture']['scene_id']}",
        "",
        f"- state: **{manifest['state']}**" + (f" - {manifest['message']}" if manifest["message"] else ""),
        f"- capture: `{manifest['capture']['path']}` (sha256 {manifest['capture']['sha256'][:12]})",
        f"- instances: {len(rows)}, missing: {len(manifest['missing'])}",
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
    create_markdown_artifact("\n".join(lines), key="rescene-report", description="ReScene run report")
    if rows:
        create_table_artifact(rows, key="rescene-instances", description="instances: view, asset, registration")


# ---- command line --------------------------------------------------------------------------------


def run_flow(
    capture: str | Path,
    run_dir: str | Path,
    config: RunConfig | None = None,
    runner: str = "thread",
    address: str | None = None,
) -> State:
    """Run the flow in this process (Prefect's embedded mode when no server is configured); returns its state."""
    flow_ = rescene
    if runner == "dask":
        from prefect_dask import DaskTaskRunner

        flow_ = rescene.with_options(task_runner=DaskTaskRunner(address=address) if address else DaskTaskRunner())
    elif runner != "thread":
        raise ValueError(f"unknown runner {runner!r}; use 'thread' or 'dask'")
    return flow_(capture=str(capture), run_dir=str(run_dir), config=config or RunConfig(), return_state=True)


def run_command(args: argparse.Namespace) -> int:
    """`rescene run CAPTURE --out RUN [--config FILE] [--set k=v] [--runner thread|dask --address A]`."""
    config = load_config(args.config, args.set)
    if getattr(args, "runner", "thread") == "dask" and not getattr(args, "address", None):
        print("no --address given: starting a local Dask cluster", file=sys.stderr)
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    start = time.perf_counter()
    state = run_flow(args.capture, args.out, config, getattr(args, "runner", "thread"), getattr(args, "address", None))
    seconds = time.perf_counter() - start
    summary = state.result(raise_on_failure=False) if state.is_completed() or state.is_failed() else None
    if isinstance(summary, CaptureError):  # bad input: the problems, and exit code 2 as for every command
        print(str(summary), file=sys.stderr)
        return 2
    print(f"{state.name}: {state.message or ''} ({seconds:.1f} s)")
    if isinstance(summary, dict):
        print(f"run directory: {summary['run_dir']}")
        for m in summary["missing"]:
            print(f"  missing {m['instance']} ({m['stage']}): {m['reason']}")
    return 0 if state.is_completed() else 1
