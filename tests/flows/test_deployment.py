"""Deployments on a real local Prefect server: pool, `deployments/deploy.py`, a process worker, and
`prefect deployment run rescene/scene` on a tiny synthetic capture; then the split flow skips it."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.flows.prefect_server import REPO
from tests.flows.prefect_server import prefect_cli as _cli


@pytest.mark.slow
@pytest.mark.timeout(1500)
def test_deployment_run_on_local_server(deploy_stack, tmp_path):
    from rescene_core.capture.synth import write_synth

    env = deploy_stack["env"]
    worker_log = deploy_stack["worker_log"]
    deploy = subprocess.run(
        [sys.executable, "deployments/deploy.py", "--prefect-file", "deployments/prefect.yaml"],
        env=env, cwd=REPO, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert deploy.returncode == 0, deploy.stderr
    capture = write_synth(tmp_path / "tiny.zarr", "tiny", seed=0)
    run_dir = tmp_path / "runs" / "tiny"
    params = json.dumps({"capture": str(capture), "run_dir": str(run_dir)})
    _cli(["deployment", "run", "rescene/scene", "--params", params, "--watch", "--watch-timeout", "600"], env, 700)
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert manifest["state"] == "Completed", (manifest["message"], worker_log.read_text()[-3000:])
    assert manifest["flow_run_id"] != "local"
    for rel in ("scene/scene.glb", "scene/scene.json", "logs/run.mcap", "eval/metrics.json"):
        assert (run_dir / rel).exists(), rel
    assert len(manifest["instances"]) >= 1

    # the split flow skips the scene already done, runs the other as a rescene/scene deployment run
    # (picked up by the worker), and writes its Parquet summary; it asks for the runs' states every second.
    # The other scene is a copy of the first under another name: not done in its own run directory, it runs
    # every stage again, and its convex decompositions come from the session's cache (a second scene's
    # CoACD runs, the longest stage of a run, would check nothing more of the deployment)
    other = Path(shutil.copytree(capture, tmp_path / "tiny1.zarr"))
    split = tmp_path / "split.txt"
    split.write_text(f"{capture}\n{other.name}\n")
    params = json.dumps({"split_file": str(split), "out_root": str(tmp_path / "runs"), "poll_interval_s": 1.0})
    _cli(
        ["deployment", "run", "rescene-split/split", "--params", params, "--watch", "--watch-timeout", "600"],
        env,
        700,
    )
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "runs" / "split_summary.parquet").to_pylist()
    assert [(r["scene"], r["skipped"], r["state"]) for r in table] == [
        ("tiny", True, "Completed"),
        ("tiny1", False, "Completed"),
    ], (table, worker_log.read_text()[-3000:])
    assert json.loads((tmp_path / "runs" / "tiny1" / "manifest.json").read_text())["state"] == "Completed"
