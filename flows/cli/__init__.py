"""The `rescene` command line. It parses arguments and calls library or flow code; nothing else.

Exit codes: 0 success, 1 the work failed, 2 bad input (a clear message, never a traceback).
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
from pathlib import Path

# Set before numpy loads OpenBLAS. The pipeline's matrix products are small (points [n, 3] times a 3x3
# rotation), where OpenBLAS's threads only spin: on this 2-core machine under load, one such product of
# 76,000 points took 22 ms of CPU (219 ms wall) threaded and 1.4 ms single-threaded, with the same result.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def parse_seeds(text: str) -> list[int]:
    """'0-4' -> [0, 1, 2, 3, 4]; '3,7,9' -> [3, 7, 9]."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if "-" in part:
            lo, hi = part.split("-", 1)
            seeds.extend(range(int(lo), int(hi) + 1))
        elif part:
            seeds.append(int(part))
    if not seeds:
        raise argparse.ArgumentTypeError(f"no seeds in {text!r}; use '0-4' or '3,7,9'")
    return seeds


def parse_frames(text: str) -> list[int]:
    """'120,600,1200' -> [120, 600, 1200]: frame counts, each at least 2."""
    try:
        counts = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: give whole numbers, e.g. 120,600,1200") from None
    if not counts or min(counts) < 2:
        raise argparse.ArgumentTypeError(f"--frames {text!r}: give frame counts of at least 2, e.g. 120,600,1200")
    return counts


def _cmd_validate(args: argparse.Namespace) -> int:
    from rescene_core.capture import check_capture, open_capture
    from rescene_core.capture.validate import check_identity

    problems = check_capture(args.capture)  # every chunk of every array decoded, then the content checked
    if not any(p.where == str(args.capture) for p in problems):  # a store that opens: its files against the stamp
        problems += check_identity(args.capture, full=args.full)
    errors = [p for p in problems if p.severity == "error"]
    for p in problems:
        print(str(p), file=sys.stderr if p.severity == "error" else sys.stdout)
    if errors:
        print(f"{args.capture}: INVALID, {len(errors)} error(s)", file=sys.stderr)
        return 2
    summary = open_capture(args.capture, validate=False).summary()
    print(json.dumps(summary, indent=2) if args.json else _format_summary(summary))
    print(f"{args.capture}: valid capture")
    return 0


def _format_summary(s: dict) -> str:
    labels = ", ".join(f"{k} x{v}" for k, v in s["labels"].items())
    return (
        f"scene {s['scene_id']} ({s['source']}): {s['frames']} frames {s['image_size'][0]}x{s['image_size'][1]}"
        f"{' with depth' if s['has_depth'] else ''}, {s['instances']} instances ({s['objects']} objects), "
        f"{s['points']} points{', ground truth' if s['has_ground_truth'] else ''}\n  labels: {labels}"
    )


def _cmd_synth(args: argparse.Namespace) -> int:
    """`rescene synth`: write the capture and its pictures, print what was made and where."""
    import time

    from rescene_core.capture.synth import make_scene, write_scene

    start = time.perf_counter()
    scene = make_scene(args.preset, args.seed)
    paths = write_scene(args.out, scene, overwrite=args.overwrite, pictures=True)
    elapsed = time.perf_counter() - start
    counts: dict[str, int] = {}
    for e in scene.events:
        counts[e["kind"]] = counts.get(e["kind"], 0) + 1
    a = scene.arrays
    print(
        f"wrote {paths['capture']}: {a.rgb.shape[0]} frames {a.rgb.shape[2]}x{a.rgb.shape[1]}, "
        f"{len(scene.gt.objects)} objects, {len(a.instances)} instances, {len(a.points)} points "
        f"({elapsed:.1f} s)"
    )
    print(f"panoptic errors: {', '.join(f'{k} {v}' for k, v in sorted(counts.items())) or 'none'}")
    for key, p in paths.items():
        if key != "capture":
            print(f"{key}: {p}")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    """`rescene run CAPTURE --out RUN [--config FILE] [--set k=v] [--runner thread|dask|ray --address A]`."""
    import os
    import time

    from rescene_core.capture import CaptureError
    from rescene_core.capture.identity import CaptureChangedError
    from rescene_core.config import load_config
    from rescene_core.runlock import RunDirectoryBusy

    config = load_config(args.config, args.set)
    if args.runner == "dask" and not args.address:
        print("no --address given: starting a local Dask cluster", file=sys.stderr)
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    from flows.scene import run_flow

    start = time.perf_counter()
    state = run_flow(args.capture, args.out, config, args.runner, args.address, verify_capture=args.verify_capture)
    seconds = time.perf_counter() - start
    summary = state.result(raise_on_failure=False) if state.is_completed() or state.is_failed() else None
    # refused before any work: a bad capture (its problems), a capture changed since its stamp (the files),
    # a run directory held by another run (the holder); exit code 2 as for every command's bad input
    if isinstance(summary, (CaptureError, CaptureChangedError, RunDirectoryBusy)):
        print(str(summary), file=sys.stderr)
        return 2
    print(f"{state.name}: {state.message or ''} ({seconds:.1f} s)")
    if isinstance(summary, dict):
        print(f"run directory: {summary['run_dir']}")
        for m in summary["missing"]:
            print(f"  missing {m['instance']} ({m['stage']}): {m['reason']}")
    return 0 if state.is_completed() else 1


def _cmd_eval(args: argparse.Namespace) -> int:
    """Write RUN/eval/metrics.json and RUN/eval/report.md, print the summary; --json also writes FILE."""
    from rescene_core.evaluation import evaluate_run
    from rescene_core.evaluation.run import format_metrics
    from rescene_core.io import write_json_atomic
    from rescene_core.paths import RunPaths

    metrics = evaluate_run(args.run)
    run = RunPaths(args.run)
    print(format_metrics(metrics))
    print(f"wrote {run.metrics} and {run.report_md}")
    if args.json:
        write_json_atomic(args.json, metrics)
    return 0


def _cmd_log(args: argparse.Namespace) -> int:
    """Print the summary of RUN/logs/run.mcap (exit 2 when there is no run log)."""
    from rescene_core.runlog.summary import format_summary, summarise

    print(format_summary(summarise(args.run)))
    return 0


def _cmd_prior_refit(args: argparse.Namespace) -> int:
    from rescene_core.scenegraph.category import save_prior
    from rescene_core.scenegraph.refit import refit_from_paths

    prior = refit_from_paths(args.inputs, args.add_to)
    save_prior(args.out, prior)
    print(f"wrote {args.out}: {len(prior.counts)} child categories")
    print(f"use it with --set scenegraph.fusion.prior_path={args.out}")
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from rescene_core.bench import SUITES, SuiteUnavailable, run_suite

    if args.list:
        print("\n".join(SUITES))
        return 0
    if args.suite not in SUITES:
        print(f"unknown suite {args.suite!r}; suites: {', '.join(SUITES)}", file=sys.stderr)
        return 2
    if args.out is None:
        print("--out DIR is required", file=sys.stderr)
        return 2
    options: dict[str, object] = {}
    if args.held_out is not None:  # only the suites with a held-out column take it; run_suite says which do not
        options["held_out"] = args.held_out
    if args.shake:
        options["shake"] = True
    if args.newton:
        options["newton"] = True
    if args.frames is not None:  # the scale suite's frame counts; run_suite refuses it for the others
        options["frames"] = args.frames
    if args.suite == "pipeline":  # the suite measures the flow: the command line hands it the Prefect harness
        from flows.bench import PrefectHarness

        options["harness"] = PrefectHarness()
    try:
        done = run_suite(args.suite, out_dir=Path(args.out), seeds=args.seeds, preset=args.preset, **options)
    except SuiteUnavailable as err:
        print(str(err))
        return 1
    print(done.table)
    print(f"wrote {done.path}")
    return 0


COMMAND_GROUPS: list[str] = ["importers", "demo", "vqa", "report", "sim"]
"""Modules of ``flows.cli`` that add sub-commands: each has ``register(sub)``, which adds its parsers to
the ``add_subparsers`` object and sets ``func`` (``args -> exit code``) on each."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="rescene", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("synth", help="generate a synthetic capture with ground truth")
    p.add_argument("out", type=Path, help="output capture, e.g. room.zarr")
    p.add_argument("--preset", default="standard", choices=["tiny", "standard", "cluttered", "egocentric"])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--overwrite", action="store_true", help="replace an existing capture")
    p.set_defaults(func=_cmd_synth)

    p = sub.add_parser("validate", help="check a capture and print its summary")
    p.add_argument("capture", type=Path)
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument(
        "--full",
        action="store_true",
        help="rehash every file against the capture's identity stamp (default: sizes, and files modified since)",
    )
    p.set_defaults(func=_cmd_validate)

    p = sub.add_parser("run", help="run the rescene flow on a capture")
    p.add_argument("capture", type=Path)
    p.add_argument("--out", type=Path, required=True, help="run directory")
    p.add_argument("--config", type=Path, help="YAML config (sections of RunConfig)")
    p.add_argument("--set", action="append", default=[], metavar="SECTION[.SUB].FIELD=VALUE")
    p.add_argument("--runner", choices=["thread", "dask", "ray"], default="thread", help="task runner")
    p.add_argument("--address", help="Dask scheduler or Ray cluster address for --runner dask|ray")
    p.add_argument(
        "--verify-capture",
        choices=["stamp", "full"],
        default="stamp",
        help="check the capture against its identity stamp by sizes and times (stamp) or by rehashing every file",
    )
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("eval", help="evaluate a run directory against the capture's ground truth")
    p.add_argument("run", type=Path)
    p.add_argument("--json", type=Path, help="also write the metrics here")
    p.set_defaults(func=_cmd_eval)

    p = sub.add_parser("log", help="summarise a run from its logs/run.mcap")
    p.add_argument("run", type=Path)
    p.set_defaults(func=_cmd_log)

    p = sub.add_parser("bench", help="run a benchmark suite; prints a table and writes DIR/<suite>.json")
    p.add_argument("suite", nargs="?")
    p.add_argument("--out", type=Path)
    p.add_argument("--seeds", type=parse_seeds, default=parse_seeds("0-4"), help="development seeds (default 0-4)")
    p.add_argument(
        "--held-out",
        type=parse_seeds,
        default=None,
        metavar="SEEDS",
        help="held-out seeds, e.g. 100-119, reported in their own block beside --seeds (sim and assembly suites)",
    )
    p.add_argument("--shake", action="store_true", help="also check each scene with the room shaken (sim suite)")
    p.add_argument(
        "--newton", action="store_true", help="also check each scene's USD in Newton (sim suite; the `newton` extra)"
    )
    p.add_argument(
        "--preset",
        default="standard",
        choices=["tiny", "standard", "cluttered", "egocentric", "all"],
        help="synthetic preset (all: standard and cluttered, in the assembly and sim suites)",
    )
    p.add_argument(
        "--frames",
        type=parse_frames,
        default=None,
        metavar="N,N,...",
        help="frame counts of the same room, e.g. 120,600,1200 (scale suite; default 120,600,1200)",
    )
    p.add_argument("--list", action="store_true", help="list the suites")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("prior-refit", help="refit the scene-graph category prior from scene graphs")
    p.add_argument("inputs", nargs="+", type=Path, help="captures with ground truth, graph.json files or run dirs")
    p.add_argument("--out", type=Path, required=True, help="the new prior table (JSON)")
    p.add_argument("--add-to", type=Path, help="add the counts to this table instead of starting empty")
    p.set_defaults(func=_cmd_prior_refit)

    for group in COMMAND_GROUPS:
        importlib.import_module(f"flows.cli.{group}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from rescene_core.capture import CaptureError

    try:
        return int(args.func(args) or 0)
    except CaptureError as err:
        print(str(err), file=sys.stderr)
        return 2
    except (FileExistsError, FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
