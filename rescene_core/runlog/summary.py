"""`rescene log RUN`: a summary of one run read back from its ``logs/run.mcap``."""

from __future__ import annotations

from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

from rescene_core.runlog.writer import RUN_LOG, read_messages


def summarise(run_dir: str | Path) -> dict[str, Any]:
    """Topics and message counts, per-stage task states, the final flow state, missing instances, metrics,
    and per stage the devices its executions' models ran on ("clip cuda:0")."""
    path = Path(run_dir) / RUN_LOG
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist; run `rescene run CAPTURE --out {run_dir}` first")
    messages = read_messages(path)
    counts = Counter(topic for topic, _, _ in messages)
    stages: dict[str, Counter] = defaultdict(Counter)
    executed: Counter = Counter()
    devices: dict[str, set[str]] = defaultdict(set)
    flow: dict[str, Any] = {}
    metrics: dict[str, dict[str, Any]] = {}
    for topic, _, msg in messages:
        if topic == "/flow/tasks":
            stages[msg["stage"]]["cached" if msg.get("cached") else msg.get("state", "?").lower()] += 1
        elif topic == "/task/events" and msg.get("event") == "end":
            executed[msg["stage"]] += 1
            devices[msg["stage"]].update(f"{k} {v}" for k, v in (msg.get("devices") or {}).items())
        elif topic == "/flow/events" and msg.get("event") == "end":
            flow = msg
        elif topic == "/metrics":
            metrics.setdefault(msg["stage"], {}).update(msg["metrics"])
    t0 = min((t for _, t, _ in messages), default=0)
    t1 = max((t for _, t, _ in messages), default=0)
    return {
        "path": str(path),
        "messages": len(messages),
        "span_seconds": round((t1 - t0) / 1e9, 3),
        "topics": dict(sorted(counts.items())),
        "stages": {k: dict(v) for k, v in stages.items()},
        "executions_logged": dict(executed),
        "devices": {k: sorted(v) for k, v in devices.items() if v},
        "state": flow.get("state"),
        "message": flow.get("message"),
        "missing": flow.get("missing", []),
        "metrics": metrics,
    }


def format_summary(s: dict[str, Any]) -> str:
    lines = [f"{s['path']}: {s['messages']} messages over {s['span_seconds']} s, final state {s['state']}"]
    if s.get("message"):
        lines.append(f"  {s['message']}")
    lines.append("topics:")
    lines += [f"  {topic:32s} {n:6d}" for topic, n in s["topics"].items()]
    lines.append("stages (task runs by final state in the last flow run; executions logged by tasks overall):")
    for stage, states in s["stages"].items():
        parts = ", ".join(f"{k} {v}" for k, v in sorted(states.items()))
        lines.append(f"  {stage:14s} {parts}  (executions logged: {s['executions_logged'].get(stage, 0)})")
    lines.append("devices of the executed stages' models (none listed: no torch model, the CPU):")
    lines += [f"  {stage:14s} {', '.join(used)}" for stage, used in sorted(s.get("devices", {}).items())]
    if s["missing"]:
        lines.append(f"missing instances ({len(s['missing'])}):")
        lines += [f"  {m['instance']:5d}  {m['stage']:12s} {m['reason']}" for m in s["missing"]]
    else:
        lines.append("missing instances: none")
    for stage, values in s["metrics"].items():
        lines.append(f"metrics [{stage}]:")
        for k, v in values.items():
            lines.append(f"  {k:32s} {v:.4g}" if isinstance(v, float) else f"  {k:32s} {v}")
    return "\n".join(lines)
