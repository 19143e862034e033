"""The operator's path with real parts: a Prefect server on a free port, the work pool, `prefect deploy`
from deployments/prefect.yaml, a process worker, `rescene/scene` on a small capture with one instance
forced to fail (RUN/faults.json), then the flow run retried with the request the UI's Retry button sends.

Only the stage libraries are the counting fakes of tests/flows/fakes.py: the flow run carries the job
variable ``env`` that puts a ``sitecustomize`` on its PYTHONPATH and switches it on, so its processes
(the first run and the retry) install them, and the test measures the orchestration, not the models."""

from __future__ import annotations

import json
import os
import time

import httpx
import pytest

from tests.flows.prefect_server import REPO, post_retrying, wait_slot_released
from tests.flows.prefect_server import prefect_cli as _cli

SITECUSTOMIZE = """
import os
if os.environ.get("RESCENE_TEST_FAKE_STAGES"):
    from rescene_core.stages import calls as stages
    from tests.flows import fakes
    for _name, _fn in fakes.STAGE_FAKES.items():
        setattr(stages, _name, _fn)
"""

UI_RETRY = {"state": {"type": "SCHEDULED", "name": "AwaitingRetry", "message": "Retry from the UI"}, "force": True}
"""The body of POST /flow_runs/{id}/set_state that the Prefect UI's Retry button sends."""


def _wait_final(api: str, flow_run_id: str, after: str | None = None, timeout: float = 300) -> dict:
    """Poll the flow run until its state is final (and differs from the state id ``after``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        run = httpx.get(f"{api}/flow_runs/{flow_run_id}", timeout=10).json()
        state = run.get("state") or {}
        if state.get("type") in ("COMPLETED", "FAILED", "CRASHED", "CANCELLED") and state.get("id") != after:
            return state
        time.sleep(0.5)
    raise AssertionError(f"flow run {flow_run_id} not final after {timeout} s")


@pytest.fixture(scope="module")
def operator_stack(deploy_stack):
    """The shared server, pool and process worker, with the deployments registered by `prefect deploy`
    and the ``env`` job variable that installs the stage fakes in a flow run's processes."""
    tmp, env = deploy_stack["tmp"], deploy_stack["env"]
    deploy = _cli(["--no-prompt", "deploy", "--all", "--prefect-file", "deployments/prefect.yaml"], env, timeout=240)
    site = tmp / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
    fake_env = {
        "RESCENE_TEST_FAKE_STAGES": "1",
        "RESCENE_RETRY_DELAY_S": "0.2",
        "PYTHONPATH": f"{site}{os.pathsep}{REPO}",
    }
    return {**deploy_stack, "deploy": deploy, "job_variables": {"env": fake_env}}


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_prefect_deploy_then_ui_retry_recomputes_only_the_failed_instance(operator_stack):
    from tests.flows.fakes import box_capture

    api, tmp = operator_stack["api"], operator_stack["tmp"]
    # `prefect deploy` registered both deployments of prefect.yaml (fastapi pinned where its worker check passes)
    names = {d["name"] for d in httpx.post(f"{api}/deployments/filter", json={}, timeout=10).json()}
    assert names == {"scene", "split"}, operator_stack["deploy"].stdout[-2000:]
    split = httpx.get(f"{api}/deployments/name/rescene-split/split", timeout=10).json()
    assert split["parameters"]["split_file"] == "deployments/splits/nightly.txt"

    capture = box_capture(tmp / "boxes.zarr")
    run_dir = tmp / "runs" / "boxes"
    run_dir.mkdir(parents=True)
    (run_dir / "faults.json").write_text(json.dumps([{"stage": "asset", "item": 3, "kind": "bad_input", "times": 1}]))
    deployment = httpx.get(f"{api}/deployments/name/rescene/scene", timeout=10).json()
    response = post_retrying(
        f"{api}/deployments/{deployment['id']}/create_flow_run",
        json={
            "parameters": {"capture": str(capture), "run_dir": str(run_dir)},
            "job_variables": operator_stack["job_variables"],
        },
    )
    assert response.status_code == 201, response.text
    flow_run = response.json()
    first = _wait_final(api, flow_run["id"])
    assert first["type"] == "FAILED", (first, operator_stack["worker_log"].read_text()[-3000:])
    assert "instances failed: 3" in first["message"]
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["failed_instances"] == [3] and manifest["flow_run_id"] == flow_run["id"]

    # the UI's Retry: the same flow run back to Scheduled (AwaitingRetry), forced; the worker picks it up
    # (once it has let go of the first run's process, as an operator reading the failure would find it)
    wait_slot_released(operator_stack["worker_log"], flow_run["id"])
    response = post_retrying(f"{api}/flow_runs/{flow_run['id']}/set_state", json=UI_RETRY)
    assert response.status_code in (200, 201), response.text
    assert response.json()["status"] == "ACCEPT"
    second = _wait_final(api, flow_run["id"], after=first["id"])
    assert second["type"] == "COMPLETED", (second, operator_stack["worker_log"].read_text()[-3000:])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["state"] == "Completed" and manifest["flow_run_id"] == flow_run["id"]
    stages = manifest["stages"]
    # only instance 3 and what depends on the set of placed instances ran again
    assert stages["asset"] == {"cached": 2, "completed": 1} and stages["registration"] == {"cached": 2, "completed": 1}
    for stage in ("shell", "view", "keyframes", "relations"):
        assert set(stages[stage]) == {"cached"}, (stage, stages[stage])
    for stage in ("fusion", "attachment", "export"):
        assert stages[stage] == {"completed": 1}, (stage, stages[stage])
    # the worker lets go of the retried run before the fixture stops it (else it waits 30 s for the process)
    wait_slot_released(operator_stack["worker_log"], flow_run["id"], times=2)
