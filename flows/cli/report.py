"""`rescene report RUN [--open]`: write RUN/eval/report.html (evaluating the run first when it has no
eval/metrics.json) and optionally open it in the default browser."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _cmd_report(args: argparse.Namespace) -> int:
    from rescene_core.evaluation import evaluate_run
    from rescene_core.evaluation.report_html import write_report_html
    from rescene_core.paths import RunPaths

    run = RunPaths(args.run)
    if not Path(args.run).is_dir():
        print(f"error: {args.run} is not a run directory", file=sys.stderr)
        return 2
    try:
        if args.evaluate or not run.metrics.exists():
            evaluate_run(args.run)
            path = run.report_html
        else:
            path = write_report_html(args.run)
    except FileNotFoundError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {path}")
    if args.open:
        import webbrowser

        if not webbrowser.open(path.resolve().as_uri()):
            print(f"no browser could be started; open {path} by hand", file=sys.stderr)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="write RUN/eval/report.html (one self-contained page) and optionally open it")
    p.add_argument("run", type=Path)
    p.add_argument("--open", action="store_true", help="open the page in the default browser")
    p.add_argument("--evaluate", action="store_true", help="evaluate the run again before writing the page")
    p.set_defaults(func=_cmd_report)
