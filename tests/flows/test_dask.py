"""The per-instance fan-out on a two-worker Dask cluster (prefect-dask), with the real stages."""

from __future__ import annotations

import json
import os

import pytest


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_flow_on_two_worker_dask_cluster(prefect_server, tmp_path):
    from distributed import LocalCluster

    from flows.scene import run_flow
    from rescene_core.capture.synth import write_synth
    from rescene_core.runlog import read_messages

    capture = write_synth(tmp_path / "tiny.zarr", "tiny", seed=0)
    run = tmp_path / "run"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        state = run_flow(capture, run, runner="dask", address=cluster.scheduler_address)
        workers = dict(cluster.workers)
    assert state.is_completed(), state.message
    assert len(workers) == 2
    manifest = json.loads((run / "manifest.json").read_text())
    n = len(manifest["instances"])
    assert n >= 1 and manifest["stages"]["registration"] == {"completed": n}
    assert (run / "scene" / "scene.glb").exists()
    # every task wrote its own segment from a worker process; the merged log holds all of them
    executed = [m for t, _, m in read_messages(run / "logs" / "run.mcap", ["/task/events"]) if m["event"] == "end"]
    assert sum(m["stage"] == "registration" for m in executed) == n
    pids = {m["pid"] for m in executed if m["stage"] in ("view", "asset", "registration")}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2  # run by the Dask worker processes
