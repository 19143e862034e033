"""The Prefect flow ``rescene``: one capture -> one run directory. Wiring only; the work is in tasks/.

Order: room shell; per instance ``.map`` over view selection -> asset -> registration; key frames and
per-key-frame relation inference (independent of the instances, so they run alongside them); fan-in
to fusion (which needs the missing instances), attachment, export, and the evaluation of every run
(against ground truth and the sensor's depth when the capture has them). Every task's result is a
reference cached on its inputs' content hashes (tasks/common.py).

An instance whose task still fails after its retries is recorded as Missing; the scene is assembled
from the rest and the flow run ends Failed with a message naming the instances, so that retrying the
flow run (``prefect flow-run retry``) re-executes only those instances and the stages after them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from uuid import UUID

from prefect import flow, get_run_logger, unmapped
from prefect.artifacts import create_progress_artifact, update_progress_artifact
from prefect.context import FlowRunContext
from prefect.futures import PrefectFuture, as_completed, wait
from prefect.states import Completed, Failed, State

from rescene_core.capture import open_capture
from rescene_core.config import RunConfig
from rescene_core.manifest import InstanceRow, StageRow, final_message, instance_row, now_iso
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Missing, Ref, Stage
from rescene_core.runlock import hold_run_directory
from rescene_core.runlog import Segment
from rescene_core.stages.dag import SPECS
from rescene_core.stages.execution import capture_ref
from rescene_core.stages.keyframes import keyframes_of
from tasks import dag as T
from tasks.common import retry_delays, vlm_slot
from tasks.run import failure_reason, finish_run, instance_outcome, state_row, write_run_config

ProgressListener = Callable[[int, int, InstanceRow], None]
PROGRESS_LISTENERS: list[ProgressListener] = []
"""Called in the flow's process as each instance finishes: (done, total, instance row). The demo's
progress bar registers here."""

PROGRESS_INTERVAL_S = 1.0
"""The progress artifact is updated as instances finish, at most once per this many seconds (and at
the end), so a burst of cached instances costs one API call, not one per instance."""


@dataclass(frozen=True)
class InstanceOutcome:
    """One instance after the fan-in: its table row, its final pose reference (None when it failed) and
    its asset task (None when the instance failed)."""

    row: InstanceRow
    pose: Ref | None = None
    asset: PrefectFuture[Ref] | None = None


def final(future: PrefectFuture[Ref]) -> PrefectFuture[Ref]:
    """``future`` once its task run has ended. A task handed a future whose end this process has not seen
    reads that task run's state from the API as it starts (Prefect looks for parent runs among its inputs):
    one request per input, which a cached rerun of the whole flow pays for every task. Used where the next
    task needs the result anyway, so nothing that could run waits."""
    future.wait()
    return future


def after_each(
    upstream: list[PrefectFuture[Ref]], submit: Callable[[PrefectFuture[Ref]], PrefectFuture[Ref]]
) -> list[PrefectFuture[Ref]]:
    """``submit(f)`` for every future of ``upstream`` as soon as its task run has ended, in upstream's order:
    the per-instance chain of ``.map`` without a task waiting on its input in a thread, and without an API
    read per input (``final``). A failed upstream task makes the submitted one NotReady, as ``.map`` does."""
    index = {f: k for k, f in enumerate(upstream)}
    out: dict[int, PrefectFuture[Ref]] = {}
    for f in as_completed(upstream):
        out[index[f]] = submit(final(f))
    return [out[k] for k in range(len(upstream))]


def _bind(task_, run: RunPaths, config: RunConfig):
    """The task with this run's result storage (cache records live in the run directory), tagged ``gpu`` only
    where the run's backend for the stage wants one (``StageSpec.wants_gpu``): every task run of a tagged task
    asks the API for a slot of the tag's concurrency limit, even with no limit set, and a busy embedded
    server answers that request with 503 and a 2 s back-off."""
    bound = task_.with_options(result_storage=run.results, retry_delay_seconds=retry_delays(task_.retries))
    if not SPECS[Stage(task_.name)].wants_gpu(config):
        bound.tags = set()  # with_options keeps the old tags when given an empty set
    return bound


@flow(name="rescene", description="Multi-view capture -> simulation-ready object-level scene (ReScene).")
def rescene(
    capture: str,
    run_dir: str,
    config: RunConfig | None = None,
    verify_capture: str = "stamp",
    runner: str = "thread",
    address: str | None = None,
) -> State[dict[str, Any]]:
    """Run ReScene on ``capture`` (a capture .zarr) into ``run_dir`` with ``config`` (defaults: the paper).

    ``verify_capture``: "stamp" checks the capture's identity stamp cheaply (sizes, files modified
    since it was written); "full" rehashes every byte against it (tasks/common.py ``capture_ref``).
    ``runner``: where the tasks run: "thread" (this process), "dask" or "ray" (a cluster at ``address``,
    or a local one when it is None); a deployment run chooses it with these parameters, and the work
    then runs as a subflow on that task runner (docs/orchestration.md).

    Returns the run's final state, Completed or Failed, whose data (the flow's result) is the summary:
    run_dir, state, instances, missing, failed_instances."""
    wanted = task_runner(runner, address)
    ctx = FlowRunContext.get()
    if wanted is not None and not (ctx and type(ctx.task_runner) is type(wanted)):
        inner = rescene.with_options(task_runner=wanted)
        st = inner(capture, run_dir, config, verify_capture, runner, address, return_state=True)
        data = st.result(raise_on_failure=False)
        return (Completed if st.is_completed() else Failed)(message=st.message, data=data)
    run = RunPaths(Path(run_dir).resolve())
    run.root.mkdir(parents=True, exist_ok=True)
    flow_ctx = FlowRunContext.get()
    flow_run_id = str(flow_ctx.flow_run.id) if flow_ctx and flow_ctx.flow_run else "local"
    # one run per run directory, held before any stage and released however the run ends; a retry of
    # this flow run (same id) or a run whose process died takes the lock over (rescene_core/runlock.py)
    holder_id = flow_run_id if flow_run_id != "local" else None  # "local" is no flow run to match
    with hold_run_directory(run.root, flow_run_id=holder_id, logger=get_run_logger()):
        return _run_scene(capture, run, config or RunConfig(), verify_capture, flow_run_id)


def _run_scene(
    capture: str, run: RunPaths, config: RunConfig, verify_capture: str, flow_run_id: str
) -> State[dict[str, Any]]:
    """The flow's work on a run directory it holds: every stage, the manifest, the final state."""
    walls = (config.export.wall_height, config.export.wall_thickness)  # how the run log draws the walls
    logger = get_run_logger()
    started = now_iso()
    write_run_config(run, config)
    flow_log = Segment(run.root, "flow")
    flow_log.log("/flow/events", {"event": "start", "flow_run_id": flow_run_id, "details": {"capture": capture}})

    capture_in = capture_ref(capture, verify_capture)
    # validation is cached on the capture's content hash: a bad capture fails here with every problem
    # listed; an unchanged one is not re-read
    _bind(T.validate_capture, run, config)(capture_in)
    cap = open_capture(capture, validate=False)
    ids = [int(i.id) for i in cap.object_instances]
    labels = {int(i.id): i.label for i in cap.object_instances}
    logger.info("capture %s: %d object instances, %d frames", cap.scene_id, len(ids), cap.num_frames)

    shell_t, views_t, keyframes_t = (
        _bind(t, run, config) for t in (T.estimate_shell, T.select_views, T.select_keyframes)
    )
    asset_t, pose_t = (_bind(t, run, config) for t in (T.generate_asset, T.register_instance))
    relations_t, fusion_t, snapshot_t, attach_t, export_t, evaluate_t = (_bind(t, run, config) for t in (
        T.predict_relations, T.fuse_graph, T.snapshot_registration, T.attach_layout, T.export, T.evaluate))  # fmt: skip
    simcheck_t = _bind(T.simcheck, run, config)
    rd, cr = unmapped(str(run.root)), unmapped(capture_in)
    rows: list[InstanceRow] = []
    stage_rows: list[StageRow] = []
    failures: list[Missing] = []
    missing: list[Missing] = []
    frame_failures: list[str] = []
    scene_error: str | None = None
    progress_id = create_progress_artifact(0.0, description=f"instances of {cap.scene_id} finished")
    assert isinstance(progress_id, UUID)  # a sync flow gets the id, not the async variant's coroutine

    try:
        shell_f = shell_t.submit(str(run.root), capture_in, config.shell)
        views_f = views_t.submit(str(run.root), capture_in, ids, config.hierview)
        keyframes_f = keyframes_t.submit(str(run.root), capture_in, config.keyframes)
        wait([views_f])
        stage_rows.append(state_row(Stage.VIEW, None, views_f))
        if views_f.state.is_completed():
            view_refs = views_f.result()
        else:  # view selection itself failed: every instance is missing at this stage
            reason = failure_reason(views_f, "view selection failed")
            failures += [Missing(InstanceId(i), Stage.VIEW, reason) for i in ids]
            view_refs = []
        assets = asset_t.map(rd, cr, view_refs, unmapped(config.assets))
        frames = keyframes_of(str(run.root), keyframes_f.result())
        preds = relations_t.map(  # every VLM request holds a slot of the shared concurrency limit
            rd, cr, unmapped(final(shell_f)), frames, unmapped(config.scenegraph), request_slot=unmapped(vlm_slot)
        )
        # each registration starts as soon as its asset is generated
        poses = after_each(assets, lambda asset: pose_t.submit(str(run.root), capture_in, asset, config.registration))

        # fan-in of the instances, reporting progress as each one finishes
        index = {fut: k for k, fut in enumerate(poses)}
        by_instance: dict[int, InstanceOutcome] = {
            m.instance: InstanceOutcome(instance_row(m.instance, labels[m.instance], None, m)) for m in failures
        }
        last_update = time.monotonic()
        for done, fut in enumerate(as_completed(list(poses)), start=1):
            k = index[fut]
            i = ids[k]
            per_stage = [(Stage.ASSET, assets[k]), (Stage.REGISTRATION, poses[k])]
            wait([f for _, f in per_stage])
            ref, miss, failed = instance_outcome(i, per_stage)
            row = instance_row(i, labels[i], view_refs[k], miss)
            if assets[k].state.is_completed():
                row = row.with_asset(assets[k].result())
            if miss is not None:
                (failures if failed else missing).append(miss)
            by_instance[i] = InstanceOutcome(row, ref, None if failed else assets[k])
            for stage, f in per_stage:
                stage_rows.append(state_row(stage, i, f))
            now = time.monotonic()
            if done == len(view_refs) or now - last_update >= PROGRESS_INTERVAL_S:
                update_progress_artifact(progress_id, 100.0 * done / max(len(ids), 1))
                last_update = now
            for listener in PROGRESS_LISTENERS:
                listener(done, len(ids), row)
        if not view_refs:
            update_progress_artifact(progress_id, 100.0)
        rows = [by_instance[i].row for i in ids]
        ok_poses = [o.pose for o in (by_instance[i] for i in ids) if o.pose is not None]
        ok_assets = [o.asset.result() for o in (by_instance[i] for i in ids) if o.asset is not None]
        all_missing = sorted(failures + missing, key=lambda m: m.instance)

        snapshot_f = snapshot_t.submit(str(run.root), capture_in, shell_f, ok_assets, ok_poses, *walls)
        wait(list(preds))
        ok_preds = []
        for frame, fut in zip(frames, preds):
            stage_rows.append(state_row(Stage.RELATIONS, frame, fut))
            if fut.state.is_completed():
                ok_preds.append(fut.result())
            else:
                logger.warning("key frame %d left out of fusion: %s", frame, fut.state.message)
                frame_failures.append(f"key frame {frame} ({fut.state.message})")
        graph_f = fusion_t.submit(str(run.root), capture_in, shell_f, ok_preds, all_missing, config.scenegraph)
        layout_f = attach_t.submit(
            str(run.root), capture_in, shell_f, final(graph_f), ok_assets, ok_poses, config.attachment, *walls
        )
        scene_f = export_t.submit(
            str(run.root), capture_in, shell_f, graph_f, final(layout_f), ok_assets, ok_poses, all_missing,
            config.export,
        )  # fmt: skip
        scene_level = [(Stage.SHELL, shell_f), (Stage.KEYFRAMES, keyframes_f), (Stage.SNAPSHOT, snapshot_f)]
        scene_level += [(Stage.FUSION, graph_f), (Stage.ATTACHMENT, layout_f), (Stage.EXPORT, scene_f)]
        sim_f = None  # the physics check of the MJCF the export wrote; the evaluation reads its result
        if config.export.simulation:
            sim_f = simcheck_t.submit(str(run.root), final(scene_f), config.sim)
            scene_level.append((Stage.SIMCHECK, sim_f))
        eval_f = evaluate_t.submit(
            str(run.root), capture_in, final(scene_f), keyframes_f, physics=None if sim_f is None else final(sim_f)
        )
        scene_level.append((Stage.EVALUATION, eval_f))
        wait([f for _, f in scene_level])
        for stage, fut in scene_level:
            stage_rows.append(state_row(stage, None, fut))
            if not fut.state.is_completed() and scene_error is None and fut.state.name != "NotReady":
                scene_error = f"{stage}: {fut.state.message}"
    except Exception as err:  # a scene-level stage could not even be scheduled or returned nothing usable
        scene_error = scene_error or f"{type(err).__name__}: {err}"
        raise
    finally:
        instance_failures = sorted(int(m.instance) for m in failures)
        message = final_message(failures, frame_failures, scene_error)
        state_name = "Failed" if message else "Completed"
        for stage_row in stage_rows:
            flow_log.log("/flow/tasks", stage_row.to_json())
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
        finish_run(
            run, capture=capture_in, scene_id=cap.scene_id, config=config, flow_run_id=flow_run_id, started=started,
            stage_rows=stage_rows, rows=rows, missing=missing_all, failed=instance_failures, state=state_name,
            message=message,
        )  # fmt: skip

    summary = {
        "run_dir": str(run.root),
        "state": state_name,
        "instances": len(ids),
        "missing": [m.to_json() for m in missing_all],
        "failed_instances": instance_failures,
    }
    if message:
        return Failed(message=message, data=summary)
    return Completed(message=f"{len(ids) - len(missing_all)} of {len(ids)} instances placed", data=summary)


# ---- running in this process --------------------------------------------------------------------------------


def run_flow(
    capture: str | Path,
    run_dir: str | Path,
    config: RunConfig | None = None,
    runner: str = "thread",
    address: str | None = None,
    verify_capture: str = "stamp",
) -> State:
    """Run the flow in this process (Prefect's embedded mode when no server is configured); returns its state."""
    wanted = task_runner(runner, address)
    flow_ = rescene if wanted is None else rescene.with_options(task_runner=wanted)
    return flow_(
        capture=str(capture),
        run_dir=str(run_dir),
        config=config or RunConfig(),
        verify_capture=verify_capture,
        runner=runner,
        address=address,
        return_state=True,
    )


RUNNERS = ("thread", "dask", "ray")


def task_runner(runner: str, address: str | None = None):
    """The Prefect task runner named ``runner`` (None for "thread", the flow's default): Dask through
    prefect-dask, Ray through prefect-ray (the ``ray`` extra); ``address`` is the cluster's scheduler
    (``tcp://host:8786``) or Ray head (``ray://host:10001``), None for a local cluster."""
    if runner == "thread":
        return None
    if runner == "dask":
        from prefect_dask import DaskTaskRunner

        return DaskTaskRunner(address=address) if address else DaskTaskRunner()
    if runner == "ray":
        try:
            from prefect_ray import RayTaskRunner
        except ImportError as err:
            raise ValueError(
                f"runner 'ray' needs prefect-ray on the worker: pip install 'rescene[ray]' ({err})"
            ) from err
        return RayTaskRunner(address=address) if address else RayTaskRunner()
    raise ValueError(f"unknown runner {runner!r}; use one of {', '.join(RUNNERS)}")
