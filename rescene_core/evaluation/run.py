"""Evaluation of a run directory: ``RUN/eval/metrics.json`` and ``RUN/eval/report.md``.

Reads the exported scene (``scene/scene.json`` and ``scene/objects/``), computes the structural
metrics (``rescene_core.evaluation.structural``) and, when the capture has ground truth, the metrics
against it (``rescene_core.evaluation.ground_truth``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, cast

import numpy as np
import trimesh

from rescene_core.io import read_json, write_bytes_atomic, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, RoomShell, SceneGraph


def load_scene(run_dir: str | Path) -> dict[str, Any]:
    """scene.json with each object's mesh loaded: objects[i]["vertices"], ["faces"] (asset frame)."""
    run = RunPaths(run_dir)
    scene_dir, path = run.scene, run.scene_json
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist; the run has not exported a scene (run `rescene run` first)")
    doc = read_json(path)
    for obj in doc["objects"]:
        # force="mesh" always gives a Trimesh; the stubs type load() as any Geometry
        mesh = cast(trimesh.Trimesh, trimesh.load(scene_dir / obj["mesh"], force="mesh", process=False))
        obj["vertices"] = np.asarray(mesh.vertices, dtype=np.float64)
        obj["faces"] = np.asarray(mesh.faces, dtype=np.int64)
    return doc


def evaluate_run(run_dir: str | Path, capture: str | Path | None = None) -> dict[str, Any]:
    """Compute and write the metrics of a run; returns them. ``capture`` defaults to the one in scene.json."""
    from rescene_core.capture import open_capture
    from rescene_core.capture.ground_truth import read_ground_truth

    run_dir = Path(run_dir)
    doc = load_scene(run_dir)
    capture = capture or doc.get("capture")
    graph = SceneGraph.from_json(doc["graph"])
    shell = RoomShell.from_json(doc["shell"]) if doc.get("shell") else None
    final = {int(o["instance"]): np.asarray(o["world_from_asset"]) for o in doc["objects"]}
    registered = {
        int(o["instance"]): np.asarray(o["registered_world_from_asset"])
        for o in doc["objects"]
        if o.get("registered_world_from_asset") is not None
    }
    metrics: dict[str, Any] = {"run_dir": str(run_dir), "capture": str(capture), "objects": len(doc["objects"])}
    metrics["missing"] = len(doc.get("missing", []))

    if shell is not None and doc["objects"]:
        from rescene_core.assembly import AssemblyObject
        from rescene_core.evaluation.structural import structural_metrics

        objs = {
            int(o["instance"]): AssemblyObject(
                InstanceId(int(o["instance"])),
                o["label"],
                o["vertices"],
                o["faces"],
                registered.get(int(o["instance"]), final[int(o["instance"])]),
            )
            for o in doc["objects"]
        }
        metrics["structural"] = structural_metrics(objs, final, graph, shell, registered=registered or None)

    gt = read_ground_truth(open_capture(capture, validate=False)) if capture else None
    if gt is not None:
        from rescene_core.evaluation.ground_truth import gt_metrics

        objects = {int(o["instance"]): (o["label"], o["vertices"], o["faces"]) for o in doc["objects"]}
        metrics["ground_truth"] = gt_metrics(objects, final, registered, graph, gt)
    metrics["summary"] = _summary(metrics)
    write_json_atomic(RunPaths(run_dir).metrics, metrics)
    write_bytes_atomic(RunPaths(run_dir).report_md, report(metrics).encode())
    return metrics


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
    return "\n".join(lines) + "\n"


def format_metrics(metrics: dict[str, Any]) -> str:
    """A short terminal rendering of the summary."""
    return "\n".join(f"{k:34s} {_fmt(v)}" for k, v in metrics["summary"].items())


__all__ = ["evaluate_run", "format_metrics", "load_scene", "report"]
