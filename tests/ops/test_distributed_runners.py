"""Distributed task runners with worker processes: the per-instance tasks of one flow run really execute in
both processes of a two-worker Dask ``LocalCluster`` (the run log's task events record each task's pid), and
the same on a local Ray where prefect-ray is installed (the ``ray`` extra). The stage libraries are the
counting fakes, installed in each worker process, so the test measures the distribution, not the models."""

from __future__ import annotations

import importlib.util
import json
import os
import time

import pytest

ASSET_S = 1.0
"""Seconds each fake asset takes: long enough that the three instances are in flight at once."""


def install_fakes(*_args) -> None:
    """Put the stage fakes into ``rescene_core.stages.calls`` of this (worker) process, the asset slowed."""
    from rescene_core.stages import calls
    from tests.flows import fakes

    for name, fn in fakes.STAGE_FAKES.items():
        setattr(calls, name, fn)

    def slow_asset(*args, **kwargs):
        time.sleep(ASSET_S)
        return fakes.generate_asset(*args, **kwargs)

    calls.generate_asset = slow_asset


def _executed_pids(run) -> dict[str, set[int]]:
    """Per stage, the pids of the processes that executed its tasks (the run log's task end events)."""
    from rescene_core.runlog import read_messages

    out: dict[str, set[int]] = {}
    for _, _, m in read_messages(run / "logs" / "run.mcap", ["/task/events"]):
        if m["event"] == "end":
            out.setdefault(m["stage"], set()).add(m["pid"])
    return out


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_instances_execute_on_both_dask_worker_processes(prefect_server, box_capture_path, tmp_path):
    from distributed import Client, LocalCluster
    from distributed.diagnostics.plugin import WorkerPlugin

    from flows.scene import run_flow

    class FakeStages(WorkerPlugin):
        def setup(self, worker):
            install_fakes()

    run = tmp_path / "run"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            client.register_plugin(FakeStages())
            worker_pids = set(client.run(os.getpid).values())
        state = run_flow(box_capture_path, run, runner="dask", address=cluster.scheduler_address)
    assert state.is_completed(), state.message
    assert len(worker_pids) == 2 and os.getpid() not in worker_pids
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["stages"]["asset"] == {"completed": 3} and manifest["stages"]["registration"] == {"completed": 3}
    pids = _executed_pids(run)
    assert pids["asset"] == worker_pids, (pids, worker_pids)  # the three instances spread over both processes
    assert all(p <= worker_pids for p in pids.values()), pids  # and every task ran in a worker, none here


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.skipif(
    importlib.util.find_spec("prefect_ray") is None,
    reason="prefect-ray is not installed (the ray extra: pip install 'rescene[ray]'; not in the CI install)",
)
def test_instances_execute_in_ray_worker_processes(prefect_server, box_capture_path, tmp_path):
    import ray

    from flows.scene import run_flow
    from tests.flows.prefect_server import REPO

    # Ray's workers start in a folder of their own: the repository on their path, for this module's hook
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    runtime_env = {"worker_process_setup_hook": install_fakes, "env_vars": {"PYTHONPATH": path}}
    ray.init(num_cpus=2, include_dashboard=False, runtime_env=runtime_env)
    try:
        address = ray.get_runtime_context().gcs_address
        state = run_flow(box_capture_path, tmp_path / "run", runner="ray", address=address)
    finally:
        ray.shutdown()
    assert state.is_completed(), state.message
    pids = _executed_pids(tmp_path / "run")
    assert os.getpid() not in pids["asset"] and len(pids["asset"]) >= 1
