"""The task runner chosen by the flow's parameters (as a deployment run passes them): thread, Dask, Ray."""

from __future__ import annotations

import importlib.util
import json

import pytest

from flows.scene import task_runner


def test_task_runner_names():
    assert task_runner("thread") is None
    assert type(task_runner("dask", "tcp://127.0.0.1:8786")).__name__ == "DaskTaskRunner"
    with pytest.raises(ValueError, match="unknown runner 'spark'; use one of thread, dask, ray"):
        task_runner("spark")


@pytest.mark.skipif(importlib.util.find_spec("prefect_ray") is not None, reason="prefect-ray is installed")
def test_ray_without_prefect_ray_is_a_clear_error():
    with pytest.raises(ValueError, match=r"pip install 'rescene\[ray\]'"):
        task_runner("ray")


def test_dask_runner_chosen_by_parameter(prefect_server, fake_stages, box_capture_path, tmp_path):
    from distributed import LocalCluster

    from flows.scene import rescene

    run = tmp_path / "run"
    # an in-process cluster, so that the tasks on its workers see the fake stages
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster:
        state = rescene(
            str(box_capture_path), str(run), runner="dask", address=cluster.scheduler_address, return_state=True
        )
    assert state.is_completed(), state.message
    assert fake_stages["asset"] == 3
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["state"] == "Completed" and manifest["stages"]["registration"] == {"completed": 3}
