"""Helpers for the fault drills: a small tmpfs to fill, and the consistency check of a run directory's
cache records against the files they stand for."""

from __future__ import annotations

import json
import subprocess
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from prefect.results import ResultRecord

from rescene_core.io import hash_file, hash_tree
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from tests.flows.prefect_server import POOL, PREFECT, REPO, WORKER_ENV

STAGES = {str(s) for s in Stage}


@contextmanager
def small_tmpfs(path: Path, size_kib: int) -> Iterator[Path]:
    """Mount a tmpfs of ``size_kib`` KiB at ``path`` (created) for the block; skips the test with the reason
    when mounting is not allowed here (not root, or a container without CAP_SYS_ADMIN)."""
    path.mkdir(parents=True, exist_ok=True)
    out = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size_kib}k,mode=0755", "tmpfs", str(path)],
        capture_output=True, text=True,
    )  # fmt: skip
    if out.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs to fill (needs root or CAP_SYS_ADMIN): {out.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


def resize_tmpfs(path: Path, size_kib: int) -> None:
    """Grow (or shrink) the tmpfs mounted at ``path`` to ``size_kib`` KiB: the space an operator frees."""
    subprocess.run(["mount", "-o", f"remount,size={size_kib}k", str(path)], check=True)


def trusted_records(run_dir: Path) -> tuple[Counter, list[str]]:
    """The stage cache records of ``run_dir`` that a later run would serve (they parse as a result record),
    counted per stage, and the problems found: a record that parses but whose reference's file is missing
    or differs from the sha256 it records (a record a later run would trust wrongly).

    Records that do not parse (cut short by a full disk or a kill) are not counted: Prefect treats them as
    absent (``ResultStore.exists`` deserialises the record) and runs the task again."""
    trusted: Counter = Counter()
    problems: list[str] = []
    for record in sorted(RunPaths(run_dir).results.iterdir()):
        stage = record.name.rsplit("-", 1)[0]
        if stage not in STAGES:
            continue  # a flow or failed-state result, not a cache record of a stage
        try:
            result = ResultRecord.deserialize(record.read_bytes()).result
        except Exception:  # noqa: BLE001 - what ResultStore.exists catches: the record counts as absent
            continue
        trusted[stage] += 1
        for ref in result if isinstance(result, list) else [result]:
            if not isinstance(ref, Ref) or ref.kind == "capture":
                continue
            # the export's reference stands for every file under scene/, each hash in its detail
            files = {f"scene/{k}": v for k, v in ref.detail["files"].items()} if ref.kind == "scene" else {}
            for path, sha in (files or {ref.path: ref.sha256}).items():
                target = run_dir / path
                if not target.exists():
                    problems.append(f"{record.name}: {path} missing")
                elif (hash_tree(target) if target.is_dir() else hash_file(target)) != sha:
                    problems.append(f"{record.name}: {path} differs from the recorded sha256")
    return trusted, problems


def leftover_temporaries(run_dir: Path) -> list[str]:
    """Temporary files of the atomic writes (``.<name>.<random>``) left under ``run_dir``, outside the
    cache records of Prefect and the run lock."""
    out = []
    for p in run_dir.rglob(".*"):
        rel = p.relative_to(run_dir)
        if rel.parts[0] in (".prefect", ".lock", ".faults"):
            continue
        out.append(str(rel))
    return out


# ---- a Prefect server on PostgreSQL, workers with the stage fakes ---------------------------------------

SITECUSTOMIZE = """
import os
if os.environ.get("RESCENE_TEST_FAKE_STAGES"):
    import json, time
    from rescene_core.stages import calls as stages
    from tests.flows import fakes
    for _name, _fn in fakes.STAGE_FAKES.items():
        setattr(stages, _name, _fn)
    _hold = os.environ.get("RESCENE_TEST_HOLD")
    if _hold:
        _register = stages.register
        def _held(*args, **kwargs):
            # a drill's hook: registration waits while the file RESCENE_TEST_HOLD exists (the run is then
            # in the middle: shell, views, assets done), telling the drill it got there
            open(f"{_hold}.reached-{os.getpid()}", "w").close()
            while os.path.exists(_hold):
                time.sleep(0.1)
            return _register(*args, **kwargs)
        stages.register = _held
    _log = os.environ.get("RESCENE_TEST_CALL_LOG")
    if _log:
        _predict = stages.predict_frame
        _pause = float(os.environ.get("RESCENE_TEST_PREDICT_S", "0.3"))
        def _timed(*args, **kwargs):
            start = time.time()
            time.sleep(_pause)  # a request long enough for requests of several processes to overlap
            out = _predict(*args, **kwargs)
            record = {"pid": os.getpid(), "start": start, "end": time.time()}
            with open(os.path.join(_log, f"{os.getpid()}-{start:.6f}.json"), "w") as f:
                json.dump(record, f)
            return out
        stages.predict_frame = _timed
"""
"""Installed through PYTHONPATH in the flow-run processes of a worker: the counting stage fakes, and (with
RESCENE_TEST_CALL_LOG) each relation request timed into a file of that folder, and (with RESCENE_TEST_HOLD)
registration held while that file exists."""

HEARTBEAT_S = 30
"""Seconds between a flow run's heartbeats in the drills (Prefect's least)."""


def fake_stage_env(tmp: Path, call_log: Path | None = None) -> dict[str, str]:
    """The environment that makes a worker's flow runs use the stage fakes (``SITECUSTOMIZE``)."""
    site = tmp / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
    env = {"RESCENE_TEST_FAKE_STAGES": "1", "RESCENE_RETRY_DELAY_S": "0.2", "PYTHONPATH": f"{site}:{REPO}"}
    if call_log is not None:
        call_log.mkdir(exist_ok=True)
        env["RESCENE_TEST_CALL_LOG"] = str(call_log)
    return env


def start_named_worker(env: dict[str, str], name: str, log: Path, limit: int = 2) -> subprocess.Popen:
    """A process worker called ``name`` on ``POOL`` in its own process group (so a drill can kill it and the
    flow runs it started at once), its output in ``log``."""
    with open(log, "w") as out:
        return subprocess.Popen(
            [PREFECT, "worker", "start", "--pool", POOL, "--name", name, "--limit", str(limit)],
            env={**env, **WORKER_ENV}, cwd=REPO, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
        )  # fmt: skip


def max_overlap(intervals: list[tuple[Any, Any]]) -> int:
    """The most intervals (start, end), seconds or datetimes, open at one instant."""
    events = sorted([(s, 1) for s, _ in intervals] + [(e, -1) for _, e in intervals], key=lambda x: (x[0], x[1]))
    open_now = best = 0
    for _, step in events:
        open_now += step
        best = max(best, open_now)
    return best


# ---- driving flow runs of the deployment from outside ----------------------------------------------------

UI_RETRY = {"state": {"type": "SCHEDULED", "name": "AwaitingRetry", "message": "Retry from the UI"}, "force": True}
"""The body of POST /flow_runs/{id}/set_state that the Prefect UI's Retry button sends."""


def create_scene_run(api: str, capture: Path, run_dir: Path, env: dict[str, str] | None = None) -> str:
    """A flow run of ``rescene/scene`` on ``capture`` into ``run_dir`` (job variable ``env`` added to its
    process environment); its id."""
    import httpx

    from tests.flows.prefect_server import post_retrying

    deployment = httpx.get(f"{api}/deployments/name/rescene/scene", timeout=10).json()
    response = post_retrying(
        f"{api}/deployments/{deployment['id']}/create_flow_run",
        json={"parameters": {"capture": str(capture), "run_dir": str(run_dir)}, "job_variables": {"env": env or {}}},
    )
    assert response.status_code == 201, response.text
    return response.json()["id"]


def wait_until(what: str, check, timeout: float, every: float = 0.25):
    """Poll ``check()`` until it returns something truthy (returned); fails naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not (value := check()):
        assert time.monotonic() < deadline, f"{what}: not after {timeout} s"
        time.sleep(every)
    return value


def flow_run_state(api: str, flow_run_id: str) -> dict:
    """The flow run's current state record (``{}`` while the server does not answer)."""
    import httpx

    try:
        return httpx.get(f"{api}/flow_runs/{flow_run_id}", timeout=10).json().get("state") or {}
    except httpx.HTTPError:
        return {}


def wait_final(api: str, flow_run_id: str, after: str | None = None, timeout: float = 300) -> dict:
    """The flow run's state once it is final (and not the state id ``after``)."""
    final = ("COMPLETED", "FAILED", "CRASHED", "CANCELLED")

    def done() -> dict | None:
        state = flow_run_state(api, flow_run_id)
        return state if state.get("type") in final and state.get("id") != after else None

    return wait_until(f"flow run {flow_run_id} final", done, timeout, every=0.5)


def claimed_by(tmp: Path, flow_run_id: str, names=("worker-a", "worker-b")) -> list[str]:
    """The workers (by their logs under ``tmp``) that the server let start the flow run."""
    line = f"Ready to submit {flow_run_id}: True"
    return [n for n in names if line in (tmp / f"{n}.log").read_text(errors="replace")]


def restart_server(server) -> None:
    """Stop the Prefect server (SIGTERM, as a service manager does) and start it again on the same port and
    database; ``server.process`` becomes the new process. Waits until it is healthy."""
    from tests.flows.prefect_server import stop, wait_healthy

    stop(server.process)
    port = server.env["PREFECT_API_URL"].rsplit(":", 1)[1].split("/", 1)[0]
    env = {k: v for k, v in server.env.items() if k != "PREFECT_API_URL"}
    with open(server.log, "a") as log:
        server.process = subprocess.Popen(
            [PREFECT, "server", "start", "--host", "127.0.0.1", "--port", port],
            env=env, cwd=server.log.parent, stdout=log, stderr=subprocess.STDOUT,
        )  # fmt: skip
    wait_healthy(server)


def stage_counts(run_dir: Path) -> dict[str, dict[str, int]]:
    """Per stage, how many task runs were cached and completed in the run's manifest."""
    return json.loads((run_dir / "manifest.json").read_text())["stages"]
