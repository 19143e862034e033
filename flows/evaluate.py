"""`rescene eval RUN [--json FILE]`: metrics of a run directory (structural, and against ground truth)."""

from __future__ import annotations

import argparse
import json
import sys

from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation.run import format_metrics


def eval_command(args: argparse.Namespace) -> int:
    """Write RUN/eval/metrics.json and RUN/eval/report.md, print the summary; --json also writes FILE."""
    try:
        metrics = evaluate_run(args.run)
    except FileNotFoundError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(format_metrics(metrics))
    print(f"wrote {args.run}/eval/metrics.json and {args.run}/eval/report.md")
    if getattr(args, "json", None):
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(metrics, indent=2, default=float))
    return 0
