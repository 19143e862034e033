"""Register the deployments of ``deployments/prefect.yaml`` with the Prefect API (``make deploy``).

prefect.yaml is the source of truth. ``prefect deploy --all --prefect-file deployments/prefect.yaml``
reads it too, but Prefect 3.8.8's CLI ends with an HTTP 422 after creating the first deployment (its
check for online workers sends ``limit: null``, which the server rejects under the pinned fastapi);
this script registers every deployment through ``RunnerDeployment.apply`` instead, which skips that
check. Run it from the repository root: each deployment gets the pull step `prefect deploy` would record
(``set_working_directory`` to that root), so workers run the flows in place.

    python deployments/deploy.py [--prefect-file deployments/prefect.yaml] [--name scene ...] [--crash-after 90]

It also creates, once per server, the automation that sets a flow run whose heartbeats stopped Crashed
(``--crash-after``; workers send heartbeats with ``PREFECT_FLOWS_HEARTBEAT_FREQUENCY=30``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import yaml


def load_deployments(prefect_file: Path) -> list[dict[str, Any]]:
    """The ``deployments`` list of a prefect.yaml (YAML anchors resolved)."""
    doc = yaml.safe_load(prefect_file.read_text()) or {}
    deployments = doc.get("deployments") or []
    if not deployments:
        raise ValueError(f"{prefect_file}: no deployments")
    return deployments


def register(spec: dict[str, Any]):
    """Create or update one deployment from its prefect.yaml entry; returns its id."""
    from prefect.deployments.runner import RunnerDeployment

    pool = spec.get("work_pool") or {}
    crons = [s["cron"] for s in spec.get("schedules") or [] if s.get("active", True) and "cron" in s]
    deployment = RunnerDeployment.from_entrypoint(
        spec["entrypoint"],
        name=spec["name"],
        cron=crons or None,
        parameters=spec.get("parameters") or {},
        description=spec.get("description"),
        tags=spec.get("tags") or [],
        work_pool_name=pool.get("name"),
        work_queue_name=pool.get("work_queue_name"),
    )
    deployment_id = deployment.apply(work_pool_name=pool.get("name"))
    # the pull step `prefect deploy` records: run the flow in this tree. Without any pull step a Prefect
    # 3.8 worker copies the deployment's whole directory (the virtual environment included, gigabytes) into
    # a temporary folder for every flow run.
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.actions import DeploymentUpdate

    here = {"prefect.deployments.steps.set_working_directory": {"directory": str(Path.cwd().resolve())}}
    with get_client(sync_client=True) as client:
        client.update_deployment(deployment_id, DeploymentUpdate(pull_steps=[here]))
    return deployment_id


CRASH_AUTOMATION = "rescene-crash-silent-flow-runs"


def crash_silent_flow_runs(within_s: int):
    """The automation Prefect documents for zombie flow runs (docs.prefect.io, "detect zombie flows"): a flow
    run that sent a heartbeat and then neither another nor a final state within ``within_s`` seconds is set
    Crashed by the server (a worker killed with its flow run). Needs heartbeats from the flow runs:
    ``PREFECT_FLOWS_HEARTBEAT_FREQUENCY`` (at least 30 s, less than ``within_s``) on the workers."""
    from datetime import timedelta

    from prefect.client.schemas.objects import StateType
    from prefect.events.actions import ChangeFlowRunState
    from prefect.events.schemas.automations import AutomationCore, EventTrigger, Posture
    from prefect.events.schemas.events import ResourceSpecification

    return AutomationCore(
        name=CRASH_AUTOMATION,
        trigger=EventTrigger(
            after={"prefect.flow-run.heartbeat"},
            expect={
                "prefect.flow-run.heartbeat",
                "prefect.flow-run.Completed",
                "prefect.flow-run.Failed",
                "prefect.flow-run.Cancelled",
                "prefect.flow-run.Crashed",
            },
            match=ResourceSpecification({"prefect.resource.id": ["prefect.flow-run.*"]}),
            for_each={"prefect.resource.id"},
            posture=Posture.Proactive,
            threshold=1,
            within=timedelta(seconds=within_s),
        ),
        actions=[ChangeFlowRunState(state=StateType.CRASHED, message="no heartbeat: the flow run's process is gone")],
    )


def ensure_crash_detection(within_s: int) -> bool:
    """Create the automation ``crash_silent_flow_runs(within_s)`` unless the server has one of its name;
    whether it was created."""
    from prefect.client.orchestration import get_client

    with get_client(sync_client=True) as client:
        if client.read_automations_by_name(CRASH_AUTOMATION):
            return False
        client.create_automation(crash_silent_flow_runs(within_s))
    return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--prefect-file", type=Path, default=Path(__file__).with_name("prefect.yaml"))
    parser.add_argument("--name", action="append", help="only these deployments (default: all)")
    parser.add_argument(
        "--crash-after",
        type=int,
        default=90,
        help="seconds without a heartbeat after which the server sets a flow run Crashed (0: no such automation)",
    )
    args = parser.parse_args(argv)
    if args.crash_after and ensure_crash_detection(args.crash_after):
        print(f"automation {CRASH_AUTOMATION}: silent flow runs Crashed after {args.crash_after} s")
    for spec in load_deployments(args.prefect_file):
        if args.name and spec["name"] not in args.name:
            continue
        deployment_id = register(spec)
        print(
            f"deployment {spec['entrypoint']} as '{spec['name']}' on pool {spec['work_pool']['name']}: {deployment_id}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
