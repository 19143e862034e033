"""`rescene vqa`: embodied VQA data from assembled scenes, data sets over many scenes, model evaluation.

rescene vqa generate RUN [--out DIR] [--views N] [--seed S] [--walk]      (also: rescene vqa RUN ...)
rescene vqa build SOURCE... --out DS [--synth PRESET --seeds 0-29] [--test-ratio R] [--per-category N]
rescene vqa eval DS [--endpoint URL --model NAME] [--no-blind] [--concurrency N] [--timeout S]
rescene vqa faithfulness RUN CAPTURE [--steps N] [--json FILE]

generate, build and faithfulness start from the `vqa` section of RunConfig (`--config FILE`, `--set
vqa.FIELD=VALUE`, as for `rescene run`); their flags apply over it. build and faithfulness have data-set
defaults of their own (e.g. 60 questions per category from a 24-step walk) for the fields that neither
the config nor a flag names.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ACTIONS = ("generate", "build", "eval", "faithfulness")
BUILD_DEFAULTS = {"per_category": 60, "sampling": "walk", "walks": 1, "walk_steps": 24, "seed": 0}
"""VqaConfig fields of `vqa build` when neither --config/--set nor a flag names them."""
FAITHFULNESS_DEFAULTS = {"per_category": 60, "walk_steps": 24, "seed": 0}
"""VqaConfig fields of `vqa faithfulness` when neither --config/--set nor a flag names them."""


def _config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", type=Path, help="YAML config (sections of RunConfig); its vqa section is the start")
    p.add_argument("--set", action="append", default=[], metavar="vqa.FIELD=VALUE", help="override a config field")


def _vqa_config(args: argparse.Namespace, defaults: dict, flags: dict):
    """RunConfig().vqa, or that of --config and --set; ``defaults`` for the fields neither of them names,
    then the ``flags`` that were given (None: not given)."""
    import yaml

    from rescene_core.config import load_config

    base = load_config(args.config, args.set).vqa
    named = {k.partition("=")[0].strip().split(".")[1] for k in args.set if k.strip().startswith("vqa.")}
    if args.config is not None:
        section = (yaml.safe_load(Path(args.config).read_text()) or {}).get("vqa") or {}
        named |= set(section)
    update = {k: v for k, v in defaults.items() if k not in named}
    update |= {k: v for k, v in flags.items() if v is not None}
    return type(base).model_validate({**base.model_dump(), **update})


def _generate_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rescene vqa generate", description="VQA questions and views of one run")
    p.add_argument("run", type=Path, help="run directory written by `rescene run`")
    p.add_argument("--out", type=Path, help="output directory (default RUN/vqa)")
    p.add_argument("--views", type=int, help="viewpoints to sample and render (default VqaConfig.views)")
    p.add_argument("--seed", type=int, help="seed of every random choice (default VqaConfig.seed)")
    p.add_argument("--walk", action="store_true", help="views from the agent's egocentric walk")
    _config_args(p)
    return p


def _build_parser() -> argparse.ArgumentParser:
    from flows.cli import parse_seeds

    p = argparse.ArgumentParser(prog="rescene vqa build", description="a VQA data set over many scenes, split by scene")
    p.add_argument("sources", nargs="*", help="run directories, captures with ground truth (*.zarr), synth:PRESET:SEED")
    p.add_argument("--out", type=Path, required=True, help="data set directory")
    p.add_argument("--synth", metavar="PRESET", help="add the ground-truth layouts of synthetic scenes of PRESET")
    p.add_argument("--seeds", type=parse_seeds, default=None, help="seeds for --synth, e.g. 0-29")
    p.add_argument("--test-ratio", type=float, default=None, help="fraction of scenes in the test split (3/13)")
    p.add_argument("--split-seed", type=int, default=0)
    p.add_argument("--per-category", type=int, help="most questions per category and scene (default 60)")
    p.add_argument("--walks", type=int, help="agent walks per scene (default 1)")
    p.add_argument("--steps", type=int, help="actions (captures) per walk (default 24)")
    p.add_argument("--seed", type=int, help="seed of scene k is SEED + k (default 0)")
    p.add_argument("--views", choices=["walk", "target"], help="how views are taken (default walk)")
    _config_args(p)
    return p


def _eval_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rescene vqa eval", description="evaluate a model on a VQA data set")
    p.add_argument("ds", type=Path, help="data set written by `rescene vqa build`")
    p.add_argument("--endpoint", help="OpenAI-compatible base URL, e.g. http://localhost:8000/v1")
    p.add_argument("--model", help="model name the endpoint serves")
    p.add_argument("--api-key-env", default="OPENAI_API_KEY", help="environment variable holding the API key")
    p.add_argument("--split", default="test")
    p.add_argument("--no-blind", action="store_true", help="skip the text-only (no image) run")
    p.add_argument("--concurrency", type=int, default=4)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per request")
    p.add_argument("--retries", type=int, default=2, help="retries per question (transport and off-format)")
    p.add_argument("--limit", type=int, help="ask only the first N questions")
    p.add_argument("--out", type=Path, help="result JSON (default DS/eval/<model>.json, and .md beside it)")
    return p


def _faithfulness_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rescene vqa faithfulness",
        description="questions from a run answered on its capture's ground truth: how often they agree",
    )
    p.add_argument("run", type=Path, help="run directory written by `rescene run`")
    p.add_argument("capture", type=Path, help="the run's capture, with ground truth (gt/)")
    p.add_argument("--steps", type=int, help="actions (captures) of the walk (default 24)")
    p.add_argument("--per-category", type=int, help="most questions per category (default 60)")
    p.add_argument("--seed", type=int, help="seed of every random choice (default 0)")
    p.add_argument("--json", type=Path, help="also write the result here")
    _config_args(p)
    return p


def _cmd_faithfulness(args: argparse.Namespace) -> int:
    from rescene_core.io import write_json_atomic
    from rescene_core.vqa.oracle import run_faithfulness

    flags = {"sampling": "walk", "walk_steps": args.steps, "per_category": args.per_category, "seed": args.seed}
    config = _vqa_config(args, FAITHFULNESS_DEFAULTS, flags)
    result = run_faithfulness(args.run, args.capture, config)
    print(
        f"{result['questions']} questions from {args.run} ({result['objects']['run']} objects; ground truth "
        f"{result['objects']['ground_truth']}): agree {result['agree']}, disagree {result['disagree']}, "
        f"unanswerable {result['unanswerable']} -> agreement {result['agreement']:.3f}"
    )
    for task, row in sorted(result["per_task"].items()):
        n = sum(row.values())
        print(
            f"  {task:<22} {row['agree']:>4} / {n:<4} agree  ({row['disagree']} disagree, {row['unanswerable']} unanswerable)"
        )
    print(f"ground-truth questions answered on the ground truth: {result['gt_self']:.3f}")
    if args.json:
        write_json_atomic(args.json, result)
    return 0


def _cmd_generate(args: argparse.Namespace) -> int:
    from rescene_core.paths import RunPaths
    from rescene_core.vqa import vqa_for_run

    flags = {"views": args.views, "seed": args.seed, "sampling": "walk" if args.walk else None}
    config = _vqa_config(args, {}, flags)
    out_dir = RunPaths(args.run).vqa if args.out is None else args.out
    summary = vqa_for_run(args.run, out_dir, config)
    print(f"{summary['questions']} questions, {len(summary['views'])} views ({summary['render_backend']}) -> {out_dir}")
    for cat, n in summary["counts"].items():
        dropped = sum(summary["filtered"][cat].values())
        print(f"  {cat:<22} {n:>4} kept  {summary['candidates'][cat]:>5} candidates  {dropped:>5} filtered")
    skipped = summary["skipped"]
    if skipped["graph"] or skipped["instances"] or skipped["edges_to_missing_instances"]:
        print(
            f"  skipped: graph {'missing' if skipped['graph'] else 'ok'}, {len(skipped['instances'])} unreadable "
            f"instances, {skipped['edges_to_missing_instances']} edges to missing instances"
        )
    return 0


def _cmd_build(args: argparse.Namespace) -> int:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from rescene_core.vqa.build import PAPER_TEST_RATIO, build_dataset, scene_source

    sources = [scene_source(s) for s in args.sources]
    if args.synth:
        sources += [scene_source(f"synth:{args.synth}:{s}") for s in (args.seeds or [0])]
    if not sources:
        print("no sources: give run directories, captures or --synth PRESET --seeds A-B", file=sys.stderr)
        return 2
    flags = {
        "seed": args.seed,
        "per_category": args.per_category,
        "sampling": args.views,
        "walks": args.walks,
        "walk_steps": args.steps,
    }
    config = _vqa_config(args, BUILD_DEFAULTS, flags)
    ratio = PAPER_TEST_RATIO if args.test_ratio is None else args.test_ratio
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, transient=False) as bar:
        task = bar.add_task("scenes", total=len(sources))
        card = build_dataset(
            sources,
            args.out,
            config,
            test_ratio=ratio,
            split_seed=args.split_seed,
            progress=lambda done, total, name: bar.update(task, completed=done, description=f"scenes ({name})"),
        )
    q = card["questions"]
    print(f"{q['train']} train + {q['test']} test questions from {len(card['scenes'])} scenes -> {args.out}")
    for split in ("train", "test"):
        print(f"  {split:<5} " + "  ".join(f"{k} {v}" for k, v in card["per_task"][split].items()))
    for f in card["failed"]:
        print(f"  failed {f['source']}: {f['error']}", file=sys.stderr)
    return 0 if card["scenes"] else 1


def _cmd_eval(args: argparse.Namespace) -> int:
    import os

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from rescene_core.io import write_bytes_atomic, write_json_atomic
    from rescene_core.vqa.evaluate import evaluate_dataset, table4_markdown

    if args.endpoint and not args.model:
        print("--model NAME is needed with --endpoint (the name the server serves)", file=sys.stderr)
        return 2
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, transient=False, disable=not args.endpoint) as bar:
        task = bar.add_task("questions", total=None)
        result = evaluate_dataset(
            args.ds,
            endpoint=args.endpoint,
            model=args.model,
            split=args.split,
            blind=not args.no_blind,
            concurrency=args.concurrency,
            timeout_s=args.timeout,
            retries=args.retries,
            limit=args.limit,
            api_key=os.environ.get(args.api_key_env) or None,
            progress=lambda done, total: bar.update(task, completed=done, total=total),
        )
    name = "".join(c if c.isalnum() or c in "-_." else "_" for c in (args.model or "baselines"))
    out = args.out or args.ds / "eval" / f"{name}.json"
    write_json_atomic(out, result)
    table = table4_markdown(result)
    write_bytes_atomic(Path(out).with_suffix(".md"), table.encode())
    print(table, end="")
    for key, row in result["rows"].items():
        if "status" in row:
            print(f"{key}: {json.dumps(row['status'])}")
    print(f"-> {out}")
    return 0


def _cmd_vqa(args: argparse.Namespace) -> int:
    from rescene_core.vqa import VqaInputError

    rest = list(args.rest)
    if rest and rest[0] in ACTIONS:
        action = rest.pop(0)
    else:
        action = "generate"
    parsers = {
        "generate": _generate_parser,
        "build": _build_parser,
        "eval": _eval_parser,
        "faithfulness": _faithfulness_parser,
    }
    sub_args = parsers[action]().parse_args(rest)
    func = {"generate": _cmd_generate, "build": _cmd_build, "eval": _cmd_eval, "faithfulness": _cmd_faithfulness}[
        action
    ]
    try:
        return func(sub_args)
    except VqaInputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


def register(sub) -> None:
    p = sub.add_parser(
        "vqa",
        help="embodied VQA: generate RUN | build SOURCE... --out DS | eval DS --endpoint URL --model NAME | "
        "faithfulness RUN CAPTURE",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("rest", nargs=argparse.REMAINDER, help="generate|build|eval|faithfulness and its arguments (or RUN)")
    p.set_defaults(func=_cmd_vqa)
