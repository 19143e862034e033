"""`rescene demo` (`make demo`): synthetic capture -> validate -> the rescene flow -> where to look.

Runs in Prefect's embedded mode (no server to start). A progress bar on stderr follows the instances
as they finish. Re-running the demo reuses the capture and every cached task.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from rescene_core.manifest import InstanceRow
from rescene_core.paths import RunPaths


def _capture(out: Path, preset: str, seed: int, console: Console) -> Path:
    from rescene_core.capture.synth import write_scene
    from rescene_core.capture.synth.scene import make_scene

    path = out / f"{preset}_seed{seed}.zarr"
    if path.exists():
        console.print(f"capture: reusing {path}")
        return path
    start = time.perf_counter()
    with console.status(f"generating the synthetic '{preset}' capture (seed {seed})"):
        write_scene(path, make_scene(preset, seed), pictures=True)
    console.print(f"capture: wrote {path} ({time.perf_counter() - start:.1f} s)")
    return path


def _cmd_demo(args: argparse.Namespace) -> int:
    """Synthetic capture -> validation -> the flow (embedded mode) -> a list of the files to open."""
    os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
    from rescene_core.capture import check_capture, open_capture

    console = Console(stderr=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    capture = _capture(out, args.preset, args.seed, console)
    problems = [p for p in check_capture(capture) if p.severity == "error"]
    if problems:
        for p in problems:
            console.print(str(p))
        return 2
    summary = open_capture(capture, validate=False).summary()
    console.print(
        f"valid capture: {summary['frames']} frames {summary['image_size'][0]}x{summary['image_size'][1]}, "
        f"{summary['objects']} objects"
    )

    from flows import scene as scene_flow

    run_dir = out / "run"
    progress = Progress(
        TextColumn("[bold]instances"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"),
        TimeElapsedColumn(), console=console, transient=False,
    )  # fmt: skip
    bar = progress.add_task("", total=summary["objects"])

    def on_instance(done: int, total: int, row: InstanceRow) -> None:
        status = row.registration if not row.missing_stage else f"missing at {row.missing_stage}"
        progress.update(bar, completed=done, total=total, description=f"{row.instance} {row.label}: {status}")

    scene_flow.PROGRESS_LISTENERS.append(on_instance)
    start = time.perf_counter()
    try:
        with progress:
            state = scene_flow.run_flow(capture, run_dir, _demo_config())
    finally:
        scene_flow.PROGRESS_LISTENERS.remove(on_instance)
    seconds = time.perf_counter() - start
    print(f"\nflow run: {state.name} in {seconds:.1f} s{': ' + state.message if state.message else ''}")
    run = RunPaths(run_dir)
    if run.layout.exists():
        from rescene_core.vqa import VqaInputError, vqa_for_run

        try:
            with console.status("generating embodied VQA questions from the assembled scene"):
                vqa = vqa_for_run(run_dir)
            console.print(f"vqa: {vqa['questions']} questions over {len(vqa['views'])} rendered views")
        except VqaInputError as err:
            console.print(f"vqa: skipped ({err})")
    if run.simcheck_newton.exists():
        _newton_summary(run.simcheck_newton, console)
    print("where to look:")
    looks = [
        ("scene (open in any glTF viewer)", run.scene_glb),
        ("scene description", run.scene_json),
        ("MuJoCo model (python -m mujoco.viewer --mjcf=PATH)", run.scene_mjcf),
        ("USD stage with physics (Isaac Sim, usdview, Blender)", run.scene_usda),
        ("export report (every guessed value, collider fallbacks)", run.export_report),
        ("physics check (stable fraction, t=0 penetration, drift)", run.simcheck),
        ("the same check in Newton on the USD, with where the engines differ", run.simcheck_newton),
        ("evaluation report", run.report_md),
        ("evaluation report, interactive (open in a browser)", run.report_html),
        ("run log (open in Foxglove Studio; `rescene log` summarises it)", run.run_log),
        ("run manifest", run.manifest),
        ("embodied VQA questions (`rescene vqa RUN` regenerates them)", run.vqa_questions),
    ]
    looks += [("picture", p) for p in sorted(out.glob(f"{capture.stem}*.png"))]
    for what, path in looks:
        mark = "" if path.exists() else "  (not written: see the flow state above)"
        print(f"  {what:64s} {path}{mark}")
    return 0 if state.is_completed() else 1


def _demo_config():
    """The default run config, with the physics check also run in Newton when the ``newton`` extra is installed
    (the demo shows both engines and where they disagree; a plain ``rescene run`` leaves it off)."""
    from importlib.util import find_spec

    from rescene_core.config import RunConfig

    config = RunConfig()
    if find_spec("newton") is None:
        return config
    return config.model_copy(update={"sim": config.sim.model_copy(update={"newton": True})})


def _newton_summary(path: Path, console: Console) -> None:
    """One line on the flow's Newton check of the USD, beside its MuJoCo check."""
    from rescene_core.io import read_json

    record = read_json(path)
    s = record["summary"]
    differ = record.get("disagreements", [])
    console.print(
        f"newton: {s['stable']}/{s['free']} free objects stable in Newton; the engines differ on {len(differ)}"
        + (f" ({', '.join(d['node'] for d in differ)})" if differ else "")
    )


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="synthetic capture -> validate -> the flow; prints where to look")
    p.add_argument("--out", type=Path, default=Path("demo"))
    p.add_argument("--preset", default="standard", choices=["tiny", "standard", "cluttered", "egocentric"])
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=_cmd_demo)
