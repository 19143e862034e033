"""Evaluation of a run directory: ``RUN/eval/metrics.json``, ``report.md`` and ``report.html``.

Reads the exported scene (``scene/scene.json`` and ``scene/objects/``) and the capture, and computes:
structural metrics (``structural``), metrics against ground truth when the capture has it
(``ground_truth``), geometry (``geometry``: against ground truth, and against the sensor's own depth
when the capture has depth), rendering fidelity (``rendering``), the physics check's results when
``sim/simcheck.json`` exists (and Newton's, ``physics_newton``, when ``sim/simcheck-newton.json`` does), and
the perceptual judge when an endpoint is configured (``judge``).
docs/evaluation.md describes the metrics.
"""

from __future__ import annotations

import hashlib
import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import trimesh
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict

from rescene_core.assembly import AssemblyObject
from rescene_core.capture import Capture, open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.evaluation.geometry import GeometryConfig, geometry_metrics
from rescene_core.evaluation.ground_truth import gt_metrics
from rescene_core.evaluation.judge import JudgeConfig, judge_run
from rescene_core.evaluation.rendering import RenderingConfig, rendering_metrics
from rescene_core.evaluation.report_html import write_report_html
from rescene_core.evaluation.scene import LoadedScene, load_scene, placed_meshes
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.export import ExportConfig, shell_meshes
from rescene_core.exported_scene import ExportedScene
from rescene_core.io import hash_file, read_json, write_bytes_atomic, write_json_atomic
from rescene_core.paths import RunPaths


class EvaluationConfig(BaseModel):
    """What the evaluation of a run computes, and how."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    geometry: GeometryConfig = GeometryConfig()
    """Geometry metrics (evaluation/geometry.py)."""
    rendering: RenderingConfig = RenderingConfig()
    """Rendering fidelity (evaluation/rendering.py)."""
    judge: JudgeConfig = JudgeConfig()
    """Perceptual judge (evaluation/judge.py); off unless an endpoint is configured."""
    html: bool = True
    """Write eval/report.html (evaluation/report_html.py)."""


def _capture_path(run_dir: Path, doc: LoadedScene | None) -> str | None:
    if doc is not None and doc.scene.capture:
        return doc.scene.capture
    manifest = RunPaths(run_dir).manifest
    if manifest.exists():
        cap = read_json(manifest).get("capture")
        if isinstance(cap, dict) and cap.get("path"):
            return str(cap["path"])
    return None


def evaluate_run(
    run_dir: str | Path,
    capture: str | Path | None = None,
    config: EvaluationConfig | None = None,
) -> dict[str, Any]:
    """Compute and write the metrics of a run; returns them. ``capture`` defaults to the one in scene.json
    (or manifest.json).

    Every metric that the run's files allow is computed; the others are listed under ``not_computed``
    with the reason (no exported scene, no capture, no depth, no ground truth, no key frames, judge off
    or down). Writes RUN/eval/metrics.json, report.md and (``config.html``) report.html.
    Raises FileNotFoundError when neither the scene nor the capture can be found.
    """
    config = config or EvaluationConfig()
    run_dir = Path(run_dir)
    started, started_cpu = time.perf_counter(), time.process_time()
    timings: dict[str, float] = {}
    not_computed: dict[str, str] = {}
    try:
        doc: LoadedScene | None = load_scene(run_dir)
    except FileNotFoundError as err:
        doc = None
        reason = f"no exported scene ({err})"
        for key in ("structural", "geometry", "rendering", "judge"):
            not_computed[key] = reason
    capture = capture or _capture_path(run_dir, doc)
    if doc is None and capture is None:
        raise FileNotFoundError(
            f"{run_dir} has neither scene/scene.json nor a capture in manifest.json; nothing to evaluate "
            "(run `rescene run CAPTURE --out RUN` first)"
        )
    metrics: dict[str, Any] = {
        "run_dir": str(run_dir),
        "capture": None if capture is None else str(capture),
        "objects": len(doc.scene.objects) if doc else 0,
        "missing": len(doc.scene.missing) if doc else None,
        "missing_records": [m.to_json() for m in doc.scene.missing] if doc else [],
    }
    cap = None
    if capture is None:
        not_computed["capture"] = "the run names no capture"
    elif not Path(capture).exists():
        not_computed["capture"] = f"the capture {capture} does not exist (moved or deleted)"
    else:
        try:
            cap = open_capture(capture, validate=False)
        except Exception as err:  # an unreadable capture must not cost the structural metrics
            not_computed["capture"] = f"the capture {capture} cannot be read: {err}"
    if cap is None:
        for key in ("ground_truth", "geometry", "rendering"):
            not_computed.setdefault(key, not_computed["capture"])

    graph = shell = None
    final: dict[int, NDArray] = {}
    registered: dict[int, NDArray] = {}
    if doc is not None:
        graph, shell = doc.scene.graph, doc.scene.shell
        final, registered = doc.final_poses(), doc.registered_poses()
        t0, c0 = time.perf_counter(), time.process_time()
        if shell is None:
            not_computed["structural"] = "scene.json has no room shell"
        elif not doc.scene.objects:
            not_computed["structural"] = "the run placed no object"
        else:
            objs = {
                int(o.instance): AssemblyObject(
                    o.instance,
                    o.label,
                    *doc.meshes[o.instance],
                    registered.get(int(o.instance), final[int(o.instance)]),
                )
                for o in doc.scene.objects
            }
            metrics["structural"] = structural_metrics(objs, final, graph, shell, registered=registered or None)
        timings["structural"] = time.perf_counter() - t0
        timings["structural_cpu"] = time.process_time() - c0

    gt = None
    if cap is not None:
        gt = read_ground_truth(cap)
        if gt is None:
            not_computed["ground_truth"] = "the capture has no ground truth (gt/ group)"
        elif doc is not None:
            t0, c0 = time.perf_counter(), time.process_time()
            objects = {int(o.instance): (o.label, *doc.meshes[o.instance]) for o in doc.scene.objects}
            metrics["ground_truth"] = gt_metrics(objects, final, registered, graph, gt)
            timings["ground_truth"] = time.perf_counter() - t0
            timings["ground_truth_cpu"] = time.process_time() - c0

    placed = placed_meshes(doc) if doc is not None else {}
    shell_geometry = {}
    if shell is not None:
        shell_geometry = shell_meshes(shell, ExportConfig())
    if cap is not None and doc is not None:
        started_early = _take_started(run_dir, capture, config)
        scene_part = started_early if started_early is not None else _scene_metrics(
            run_dir, placed, shell_geometry, cap, gt, config
        )  # fmt: skip
        metrics.update(scene_part.metrics)
        timings.update(scene_part.timings)
        not_computed.update(scene_part.not_computed)

    checks = (
        ("physics", RunPaths(run_dir).simcheck, "run `rescene simcheck RUN`"),
        (
            "physics_newton",
            RunPaths(run_dir).simcheck_newton,
            "`--set sim.newton=true` in the flow, or `rescene simcheck RUN --engine newton`",
        ),
    )
    for key, path, how in checks:  # the physics checks' own files, as they are
        if not path.exists():
            not_computed[key] = f"no {path.parent.name}/{path.name} ({how})"
            continue
        try:
            metrics[key] = read_json(path)
        except ValueError as err:
            not_computed[key] = f"{path} is not valid JSON: {err}"

    if doc is not None and cap is not None:
        t0, c0 = time.perf_counter(), time.process_time()
        metrics["judge"] = judge_run(run_dir, placed, shell_geometry, cap, config.judge)
        timings["judge"] = time.perf_counter() - t0
        timings["judge_cpu"] = time.process_time() - c0
    for section in ("geometry", "rendering"):
        for key, reason in metrics.get(section, {}).get("not_computed", {}).items():
            not_computed[f"{section}.{key}"] = reason
    judge = metrics.get("judge", {})
    if judge.get("status") != "ok":
        not_computed["judge"] = judge.get("reason", not_computed.get("judge", "not run"))
    timings["total_excluding_judge"] = time.perf_counter() - started - timings.get("judge", 0.0)
    timings["total_excluding_judge_cpu"] = time.process_time() - started_cpu - timings.get("judge_cpu", 0.0)
    metrics["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
    metrics["not_computed"] = not_computed
    metrics["summary"] = _summary(metrics)
    write_json_atomic(RunPaths(run_dir).metrics, metrics)
    write_bytes_atomic(RunPaths(run_dir).report_md, report(metrics).encode())
    if config.html:
        write_report_html(run_dir, metrics)
    return metrics


@dataclass(frozen=True)
class SceneMetrics:
    """The geometry and rendering sections of the metrics (the bulk of the evaluation's time), their
    timings and what they could not compute."""

    metrics: dict[str, Any]
    timings: dict[str, float]
    not_computed: dict[str, str]


def _scene_metrics(
    run_dir: Path,
    placed: dict[int, tuple[str, trimesh.Trimesh]],
    shell_geometry: dict[str, trimesh.Trimesh],
    cap: Capture,
    gt: Any,
    config: EvaluationConfig,
) -> SceneMetrics:
    """Geometry and rendering metrics of the placed scene against the capture (and ``gt`` when given)."""
    timings: dict[str, float] = {}
    not_computed: dict[str, str] = {}
    t0, c0 = time.perf_counter(), time.process_time()
    geometry = geometry_metrics(placed, shell_geometry, cap, gt, config.geometry)
    timings["geometry"] = time.perf_counter() - t0
    timings["geometry_cpu"] = time.process_time() - c0
    key_frames = None
    kf_path = RunPaths(run_dir).keyframes
    if kf_path.exists():
        key_frames = [int(t) for t in read_json(kf_path).get("frames", [])]
    else:
        not_computed["key_frames"] = "no keyframes.json: rendering is compared on every frame"
    t0, c0 = time.perf_counter(), time.process_time()
    rendering = rendering_metrics(placed, shell_geometry, cap, key_frames, config.rendering)
    timings["rendering"] = time.perf_counter() - t0
    timings["rendering_cpu"] = time.process_time() - c0
    return SceneMetrics({"geometry": geometry, "rendering": rendering}, timings, not_computed)


# ---- the scene metrics started early --------------------------------------------------------------------------

_STARTED: dict[str, Future[SceneMetrics]] = {}
"""Scene metrics started in this process before the evaluation (``start_scene_metrics``), by the key of what
they read (``_inputs_key``); each is taken once."""
_STARTED_LOCK = threading.Lock()
MAX_STARTED = 4
"""At most this many started and not yet taken (the oldest is dropped: its evaluation computes again)."""


def _inputs_key(run_dir: Path, capture: str | Path | None, config: EvaluationConfig) -> str | None:
    """sha256 of everything ``_scene_metrics`` reads from the run directory (scene.json, each object's mesh
    file, keyframes.json), the capture's path and the config; None without an exported scene."""
    run = RunPaths(run_dir)
    if capture is None or not run.scene_json.exists():
        return None
    h = hashlib.sha256(f"{Path(run_dir).resolve()}|{Path(capture).resolve()}|{config.model_dump_json()}".encode())
    h.update(hash_file(run.scene_json).encode())
    for obj in ExportedScene.read(run.scene_json).objects:
        mesh = run.scene / obj.mesh
        h.update(hash_file(mesh).encode() if mesh.exists() else b"absent")
    h.update(hash_file(run.keyframes).encode() if run.keyframes.exists() else b"absent")
    return h.hexdigest()


def start_scene_metrics(run_dir: str | Path, capture: str | Path, config: EvaluationConfig | None = None) -> None:
    """Start the geometry and rendering metrics of the run's exported scene in a thread of this process, for
    ``evaluate_run`` to take when it reads the same files (else it computes them itself, and what was
    started is dropped). The export calls it once the visual scene (scene.json, objects/) is written and
    before the collision decomposition, whose worker processes it then runs beside: the evaluation waits
    for the physics check, which waits for the decomposition, though these metrics read neither.
    The same functions on the same files: the metrics are the same either way."""
    config = config or EvaluationConfig()
    run_dir = Path(run_dir)
    key = _inputs_key(run_dir, capture, config)
    if key is None:
        return

    def compute() -> SceneMetrics:
        doc = load_scene(run_dir)
        cap = open_capture(capture, validate=False)
        gt = read_ground_truth(cap)
        shell = shell_meshes(doc.scene.shell, ExportConfig()) if doc.scene.shell is not None else {}
        return _scene_metrics(run_dir, placed_meshes(doc), shell, cap, gt, config)

    # the native libraries the metrics load on first use are loaded here, in the calling thread, before the
    # thread starts: loading one while another thread runs numpy can deadlock (rescene_core/export/usd.py:load_usd)
    import open3d  # noqa: F401
    from skimage.metrics import structural_similarity  # noqa: F401

    future: Future[SceneMetrics] = Future()

    def work() -> None:
        try:
            future.set_result(compute())
        except BaseException as err:  # noqa: BLE001 - handed to the evaluation, which computes again
            future.set_exception(err)

    with _STARTED_LOCK:
        _STARTED[key] = future
        while len(_STARTED) > MAX_STARTED:
            _STARTED.pop(next(iter(_STARTED)))
    threading.Thread(target=work, name="rescene-scene-metrics", daemon=True).start()


def _take_started(run_dir: Path, capture: str | Path | None, config: EvaluationConfig) -> SceneMetrics | None:
    """The scene metrics started for exactly these inputs, once they are done; None when none were (or
    they failed: the evaluation then computes them itself, and any error is raised there)."""
    with _STARTED_LOCK:
        if not _STARTED:
            return None
    key = _inputs_key(run_dir, capture, config)
    with _STARTED_LOCK:
        future = _STARTED.pop(key, None) if key is not None else None
    if future is None:
        return None
    try:
        return future.result()
    except Exception:  # noqa: BLE001 - computed again in the evaluation, where an error is reported
        return None


def _summary(metrics: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {"objects": metrics["objects"], "missing": metrics["missing"]}
    for key, value in metrics.get("structural", {}).items():
        if isinstance(value, int | float) or value is None:
            out[f"structural_{key}"] = value
    gt = metrics.get("ground_truth")
    if gt:
        for key in (
            "recall",
            "scene_chamfer",
            "mean_final_centre_error",
            "mean_final_chamfer",
            "mean_registered_centre_error",
        ):
            out[key] = gt[key]
        for key in ("edge_accuracy", "edge_precision"):
            out[f"graph_{key}"] = gt["graph"][key]
    geo = metrics.get("geometry", {})
    for ref, modes in (("ground_truth", ("sampled", "refused")), ("sensor", ("objects_refused", "all_refused"))):
        for mode in modes:
            m = geo.get(ref, {}).get(mode)
            if m:
                for key in ("chamfer", "fscore@5cm", "normal_consistency"):
                    out[f"geometry_{ref}_{mode}_{key}"] = m[key]
    ren = metrics.get("rendering", {})
    for key in ("psnr_masked", "ssim_masked", "psnr", "ssim", "lpips", "mask_iou_mean_placed"):
        if key in ren:
            out[f"rendering_{key}"] = ren[key]
    for key, value in (ren.get("depth") or {}).items():
        if key in ("abs_rel", "rmse", "delta_1.25"):
            out[f"rendering_depth_{key}"] = value
    judge = metrics.get("judge", {})
    for axis, value in (judge.get("scores") or {}).items():
        out[f"judge_{axis}"] = value
    return out


def _fmt(v: Any) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def report(metrics: dict[str, Any]) -> str:
    """The markdown report of ``metrics``."""
    lines = [f"# Evaluation of {metrics['run_dir']}", "", f"capture: `{metrics['capture']}`", ""]
    lines += ["| metric | value |", "|---|---|"]
    lines += [f"| {k} | {_fmt(v)} |" for k, v in metrics["summary"].items()]
    gt = metrics.get("ground_truth")
    if gt:
        lines += ["", "## Per object (against ground truth)", ""]
        lines += ["| instance | label | object | centre error (m) | chamfer (m) | registered centre error (m) |"]
        lines += ["|---|---|---|---|---|---|"]
        for r in gt["per_object"]:
            lines.append(
                f"| {r['instance']} | {r['label']} | {_fmt(r['object_id'])} | {_fmt(r.get('final_centre_error'))} | "
                f"{_fmt(r.get('final_chamfer'))} | {_fmt(r.get('registered_centre_error'))} |"
            )
        lines += ["", "## Scene graph", ""]
        lines += [f"- {k}: {_fmt(v)}" for k, v in gt["graph"].items()]
    geo = metrics.get("geometry", {})
    for ref in ("ground_truth", "sensor"):
        rows = geo.get(ref, {}).get("per_object")
        if not rows:
            continue
        lines += [
            "",
            f"## Geometry per object (against {'ground truth' if ref == 'ground_truth' else 'the sensor'})",
            "",
        ]
        lines += ["| instance | label | mode | CD (m) | F@5cm | NC |", "|---|---|---|---|---|---|"]
        for r in rows:
            for mode in ("sampled", "refused"):
                m = r.get(mode)
                if m:
                    lines.append(
                        f"| {r['instance']} | {r['label']} | {mode} | {_fmt(m['chamfer'])} | "
                        f"{_fmt(m['fscore@5cm'])} | {_fmt(m['normal_consistency'])} |"
                    )
    ren = metrics.get("rendering", {})
    if ren.get("per_object"):
        lines += ["", "## Instance-mask IoU (rendered vs captured, non-key frames)", ""]
        lines += ["| instance | label | placed | IoU |", "|---|---|---|---|"]
        lines += [f"| {r['instance']} | {r['label']} | {r['placed']} | {_fmt(r['iou'])} |" for r in ren["per_object"]]
    if metrics.get("not_computed"):
        lines += ["", "## Not computed", ""]
        lines += [f"- {k}: {v}" for k, v in metrics["not_computed"].items()]
    if metrics.get("timings_s"):
        lines += ["", "## Time (s)", ""]
        lines += [f"- {k}: {v}" for k, v in metrics["timings_s"].items()]
    return "\n".join(lines) + "\n"


def format_metrics(metrics: dict[str, Any]) -> str:
    """A short terminal rendering of the summary."""
    return "\n".join(f"{k:34s} {_fmt(v)}" for k, v in metrics["summary"].items())


__all__ = ["EvaluationConfig", "evaluate_run", "format_metrics", "report"]
