"""The synthetic captures and pipeline runs that several benchmark suites measure, made once per work folder.

Layout under a suite's work folder: ``captures/<preset>_seed<seed>.zarr`` and ``runs/<preset>_seed<seed>``
(or a run folder of the caller's choosing). A capture or run that is already there is reused, so suites
and their re-runs share the expensive pipeline runs.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from rescene_core.capture.format import Capture
from rescene_core.capture.ground_truth import GroundTruth, read_ground_truth
from rescene_core.capture.synth import write_synth
from rescene_core.paths import RunPaths


def synth_capture(work_dir: Path, preset: str, seed: int) -> Path:
    """``work_dir/captures/<preset>_seed<seed>.zarr``, written by the synthetic generator when missing."""

    capture = work_dir / "captures" / f"{preset}_seed{seed}.zarr"
    if not capture.exists():
        write_synth(capture, preset=preset, seed=seed)
    return capture


def synth_ground_truth(capture: Capture | str | Path) -> GroundTruth:
    """The ground truth a suite measures against; ValueError when the capture has none (not a synthetic one)."""
    gt = read_ground_truth(capture)
    if gt is None:
        name = capture.path if isinstance(capture, Capture) else capture
        raise ValueError(f"{name} has no ground truth; benchmarks need synthetic captures")
    return gt


def pipeline_run(
    capture: Path, run_dir: Path, settings: Sequence[str] = (), accept_failed_with_scene: bool = False
) -> Path:
    """``rescene run CAPTURE --out RUN_DIR [--set S ...]`` in a subprocess, unless the run already has its scene.

    A run that exits non-zero raises with the end of its output, except, with ``accept_failed_with_scene``,
    a run that still wrote its scene (a Failed run whose missing instances are recorded)."""
    paths = RunPaths(run_dir)
    if paths.scene_json.exists():
        return run_dir
    cmd = [str(Path(sys.executable).with_name("rescene")), "run", str(capture), "--out", str(run_dir)]
    for setting in settings:
        cmd += ["--set", setting]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0 and not (accept_failed_with_scene and paths.scene_json.exists()):
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-15:])
        raise RuntimeError(f"{' '.join(cmd)} exited {done.returncode}:\n{tail}")
    return run_dir
