"""Deployments on a real local Prefect server: pool, `prefect deploy`, a process worker, and
`prefect deployment run rescene/scene` on a tiny synthetic capture; then the split flow skips it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.flows.prefect_server import PREFECT, REPO, local_server, stop
from tests.flows.prefect_server import prefect_cli as _cli


@pytest.mark.slow
@pytest.mark.timeout(1500)
def test_deployment_run_on_local_server(tmp_path):
    from rescene_core.capture.synth import write_synth

    with local_server(tmp_path) as env:
        worker = None
        try:
            _cli(["work-pool", "create", "rescene-local", "--type", "process", "--overwrite"], env)
            deploy = subprocess.run(
                [sys.executable, "deployments/deploy.py", "--prefect-file", "deployments/prefect.yaml"],
                env=env, cwd=REPO, capture_output=True, text=True, timeout=300,
            )  # fmt: skip
            assert deploy.returncode == 0, deploy.stderr
            worker = subprocess.Popen(
                [PREFECT, "worker", "start", "--pool", "rescene-local", "--limit", "2"],
                env=env, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )  # fmt: skip
            capture = write_synth(tmp_path / "tiny.zarr", "tiny", seed=0)
            run_dir = tmp_path / "runs" / "tiny"
            params = json.dumps({"capture": str(capture), "run_dir": str(run_dir)})
            _cli(
                ["deployment", "run", "rescene/scene", "--params", params, "--watch", "--watch-timeout", "600"],
                env,
                700,
            )
            manifest = json.loads((run_dir / "manifest.json").read_text())
            assert manifest["state"] == "Completed", manifest["message"]
            assert manifest["flow_run_id"] != "local"
            for rel in ("scene/scene.glb", "scene/scene.json", "logs/run.mcap", "eval/metrics.json"):
                assert (run_dir / rel).exists(), rel
            assert len(manifest["instances"]) >= 1

            # the split flow skips the scene already done, runs the other as a rescene/scene deployment run
            # (picked up by the worker), and writes its Parquet summary
            other = write_synth(tmp_path / "tiny1.zarr", "tiny", seed=1)
            split = tmp_path / "split.txt"
            split.write_text(f"{capture}\n{other.name}\n")
            params = json.dumps({"split_file": str(split), "out_root": str(tmp_path / "runs")})
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
            ]
            assert json.loads((tmp_path / "runs" / "tiny1" / "manifest.json").read_text())["state"] == "Completed"
        finally:
            stop(worker)
