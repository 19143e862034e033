"""`rescene bench scenegraph`: relation accuracy of the scene graph on synthetic scenes (paper Table 3(b)).

Per seed: the synthetic capture (kept under the work directory and reused), the room shell estimated
from the capture, the key frames by greedy 3D coverage, per-frame relations from the weight-free
geometric backend, then three ways of turning them into a graph:

- single frame: each child's relation from the one key frame that shows it largest (no fusion);
- multi-frame vote: argmax of the vote ratio V over the key frames (cycles broken as in fusion);
- full fusion: S = alpha V + beta G + gamma Phi (+ room-shell prior), paper Appendix weights.

Against the ground truth over capture instances (``GroundTruth.graph_by_instance``): edge_accuracy
(relation and parent object both right), anchor_resolved_ratio (instances whose parent chain reaches
floor or wall), uncertain_ratio (edges flagged uncertain), seconds, and for full fusion wall_id_accuracy:
over the ground-truth `mounts-on wall` edges that fusion also hangs on a wall, the fraction whose
``wall_id`` names the right wall (the estimated shell's walls are matched to the ground-truth walls by
plane geometry, since the two number their walls independently).

A second run sends the same frames through the `openai` client to a scripted loopback endpoint that
answers malformed JSON in 30% of calls and the geometric backend's answer otherwise: it measures that the
pipeline completes with a valid graph and counts the validation retries. It is not a model.
"""

from __future__ import annotations

import base64
import hashlib
import random
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.capture.synth import write_synth
from rescene_core.config import KeyFrameConfig, SceneGraphConfig, ShellConfig, VlmClientConfig
from rescene_core.hierview import select_keyframes
from rescene_core.records import Root, SceneGraph
from rescene_core.scenegraph import FramePrediction, fuse_with_report, make_predictor, predict_frames
from rescene_core.scenegraph.frame import render_overlay
from rescene_core.scenegraph.loopback import LoopbackServer, Reply, image_url
from rescene_core.scenegraph.overlay import png_bytes
from rescene_core.shell import estimate_shell

WALL_MATCH_DEG = 15.0
"""An estimated wall matches a ground-truth wall when their normals differ by at most this (deg) ..."""
WALL_MATCH_OFFSET = 0.30
"""... and their planes by at most this along the normal (m); the nearest such wall is the match."""
MALFORMED_RATE = 0.30
"""Fraction of loopback calls answered with malformed JSON."""
VARIANTS = ("single_frame", "vote", "full")


def _capture(work_dir: Path, preset: str, seed: int):

    path = work_dir / f"{preset}_{seed}.zarr"
    if not path.exists():
        write_synth(path, preset=preset, seed=seed)
    return open_capture(path)


def _shell(capture, gt):
    try:
        return estimate_shell(capture, ShellConfig()), "estimated"
    except Exception as err:  # report and use the ground-truth shell rather than stop the suite
        return gt.shell, f"ground truth ({type(err).__name__}: {err})"


def _keyframes(capture) -> tuple[list[int], str]:

    return list(select_keyframes(capture, KeyFrameConfig()).frames), "greedy 3D coverage"


def single_frame_graph(predictions: list[FramePrediction], children: list[int]) -> dict[int, tuple]:
    """Each child's (relation, parent) from the usable frame showing it with the most pixels."""
    best: dict[int, tuple[int, tuple]] = {}
    for p in predictions:
        if not p.usable:
            continue
        for v in p.visible:
            rel = p.relations.get(v.instance)
            if rel is not None and (int(v.instance) not in best or v.pixels > best[int(v.instance)][0]):
                best[int(v.instance)] = (v.pixels, rel)
    return {c: best[c][1] for c in children if c in best}


def anchor_resolved(edges: dict[int, tuple], children: list[int]) -> float:
    """Fraction of ``children`` whose chain of parents reaches floor or wall (no gap, no cycle)."""
    ok = 0
    for c in children:
        node, seen = c, set()
        while True:
            if node not in edges or node in seen:
                break
            seen.add(node)
            parent = edges[node][1]
            if isinstance(parent, Root):
                ok += 1
                break
            node = int(parent)
    return ok / len(children) if children else 1.0


def edge_accuracy(edges: dict[int, tuple], gt_graph: SceneGraph, object_of: dict[int, int]) -> float:
    """Fraction of ground-truth edges whose child has the same relation and the same parent object."""
    right = 0
    for e in gt_graph.edges:
        got = edges.get(int(e.child))
        if got is None or got[0] != e.relation:
            continue
        if isinstance(e.parent, Root):
            right += got[1] == e.parent
        elif not isinstance(got[1], Root):
            right += object_of.get(int(got[1])) == object_of.get(int(e.parent))
    return right / len(gt_graph.edges) if gt_graph.edges else 1.0


def match_walls(estimated, truth) -> dict[int, int]:
    """Estimated wall id -> ground-truth wall id, matched by plane geometry (normal within WALL_MATCH_DEG,
    offset within WALL_MATCH_OFFSET, nearest offset first; segments' midpoints break ties). Unmatched
    estimated walls are left out."""

    out = {}
    cos_tol = np.cos(np.deg2rad(WALL_MATCH_DEG))
    for w in estimated.walls:
        n = np.asarray(w.plane.normal, np.float64)
        mid = np.mean(np.asarray(w.segment, np.float64), axis=0)
        best, best_key = None, None
        for g in truth.walls:
            if float(n @ np.asarray(g.plane.normal, np.float64)) < cos_tol:
                continue
            off = abs(float(w.plane.offset) - float(g.plane.offset))
            if off > WALL_MATCH_OFFSET:
                continue
            key = (round(off, 2), float(np.linalg.norm(np.mean(np.asarray(g.segment, np.float64), axis=0) - mid)))
            if best_key is None or key < best_key:
                best, best_key = g.id, key
        if best is not None:
            out[int(w.id)] = int(best)
    return out


def wall_id_accuracy(graph: SceneGraph, gt_graph: SceneGraph, wall_map: dict[int, int]) -> tuple[float | None, int]:
    """(fraction right, count) over ground-truth mounts-on-wall edges that ``graph`` also hangs on a wall:
    right when the edge's wall_id maps (``wall_map``: its shell's id -> ground-truth id) to the ground
    truth's wall. None when there are no such edges."""
    got = {int(e.child): e for e in graph.edges}
    right = total = 0
    for e in gt_graph.edges:
        g = got.get(int(e.child))
        if e.parent != Root.WALL or e.wall_id is None or g is None or g.parent != Root.WALL:
            continue
        total += 1
        right += g.wall_id is not None and wall_map.get(int(g.wall_id)) == int(e.wall_id)
    return (right / total if total else None), total


def _loopback_run(capture, frames, shell, geometric: list[FramePrediction], seed: int) -> dict[str, Any]:
    """The openai client against a loopback endpoint answering malformed JSON in 30% of calls."""
    answers = {}
    for p in geometric:
        raws = [a.raw for a in p.attempts if a.raw is not None]
        if raws:
            answers[p.frame] = raws[-1]
    rng = random.Random(seed)
    by_image: dict[str, str] = {}
    stats = {"calls": 0, "malformed": 0}

    cfg0 = SceneGraphConfig()

    for t in frames:
        _, image, _ = render_overlay(capture, t, cfg0)
        url = "data:image/png;base64," + base64.b64encode(png_bytes(image)).decode()
        by_image[hashlib.sha256(url.encode()).hexdigest()] = answers.get(t, '{"objects": []}')

    def script(request: dict[str, Any]) -> Reply:
        stats["calls"] += 1
        if rng.random() < MALFORMED_RATE:
            stats["malformed"] += 1
            return Reply(content='{"objects": [{"id": 1, "category": ')
        if request.get("response_format", {}).get("json_schema", {}).get("name") == "rescene_ab":
            return Reply(content='{"answer": "A"}')
        key = hashlib.sha256(image_url(request).encode()).hexdigest()
        return Reply(content=by_image.get(key, '{"objects": []}'))

    start = time.perf_counter()
    with LoopbackServer(script) as server:
        cfg = SceneGraphConfig(
            backend="openai", vlm=VlmClientConfig(base_url=server.base_url, timeout_s=30.0, backoff_s=0.05)
        )
        predictor = make_predictor(cfg)
        preds = predict_frames(capture, frames, shell, cfg, predictor)
        graph, report = fuse_with_report(preds, capture, shell, cfg, predictor=predictor)
        close = getattr(predictor, "close", None)  # the OpenAI-compatible backend holds an HTTP client
        if close is not None:
            close()
    statuses = {s: sum(p.status == s for p in preds) for s in ("ok", "partial", "failed", "empty")}
    return {
        "graph": graph,
        "calls": stats["calls"],
        "malformed_answers": stats["malformed"],
        "validation_retries": sum(p.retries for p in preds),
        "frame_status": statuses,
        "ab_rechecks": len(report.ab),
        "graph_valid": graph.check() == [],
        "seconds": time.perf_counter() - start,
    }


def run_seed(preset: str, seed: int, work_dir: Path) -> dict[str, Any]:

    t0 = time.perf_counter()
    capture = _capture(work_dir, preset, seed)
    synth_s = time.perf_counter() - t0
    gt = read_ground_truth(capture)
    if gt is None:
        raise ValueError(f"{capture.path} has no ground truth")
    gt_graph = gt.graph_by_instance()
    object_of = gt.object_of_instance()
    shell, shell_source = _shell(capture, gt)
    frames, frames_source = _keyframes(capture)
    cfg = SceneGraphConfig()
    t0 = time.perf_counter()
    preds = predict_frames(capture, frames, shell, cfg, make_predictor(cfg))
    predict_s = time.perf_counter() - t0
    children = [int(i.id) for i in capture.object_instances]
    out: dict[str, Any] = {
        "seed": seed,
        "objects": len(gt.objects),
        "gt_edges": len(gt_graph.edges),
        "instances": len(children),
        "key_frames": len(frames),
        "key_frames_source": frames_source,
        "shell_source": shell_source,
        "synth_seconds": round(synth_s, 2),
        "predict_seconds": round(predict_s, 3),
    }
    single = single_frame_graph(preds, children)
    out["single_frame"] = {
        "edge_accuracy": edge_accuracy(single, gt_graph, object_of),
        "anchor_resolved_ratio": anchor_resolved(single, children),
        "uncertain_ratio": None,
        "seconds": predict_s,
    }
    for variant in ("vote", "full"):
        t0 = time.perf_counter()
        graph, report = fuse_with_report(preds, capture, shell, cfg, variant=variant)
        fuse_s = time.perf_counter() - t0
        edges = {int(e.child): (e.relation, e.parent) for e in graph.edges}
        out[variant] = {
            "edge_accuracy": edge_accuracy(edges, gt_graph, object_of),
            "anchor_resolved_ratio": anchor_resolved(edges, children),
            "uncertain_ratio": len(report.uncertain) / max(1, len(graph.edges)),
            "low_confidence_ratio": len(report.low_confidence) / max(1, len(graph.edges)),
            "cycles_broken": len(report.cycles_broken),
            "seconds": predict_s + fuse_s,
            "graph_valid": graph.check() == [],
        }
        if variant == "full":
            out["full"]["errors"] = _errors(edges, gt_graph, object_of, capture)
            wall_map = match_walls(shell, gt.shell)
            acc, n = wall_id_accuracy(graph, gt_graph, wall_map)
            out["full"]["wall_id_accuracy"] = acc
            out["full"]["wall_edges"] = n
            out["full"]["wall_id_errors"] = _wall_errors(graph, gt_graph, wall_map, capture)
    loop = _loopback_run(capture, frames, shell, preds, seed)
    edges = {int(e.child): (e.relation, e.parent) for e in loop.pop("graph").edges}
    loop["edge_accuracy"] = edge_accuracy(edges, gt_graph, object_of)
    loop["seconds"] = round(loop["seconds"], 3)
    out["loopback_malformed_30"] = loop
    return out


def _wall_errors(graph, gt_graph, wall_map, capture) -> list[str]:
    """Wall edges of ``graph`` on the wrong wall (ground-truth wall ids)."""
    got = {int(e.child): e for e in graph.edges}
    out = []
    for e in gt_graph.edges:
        g = got.get(int(e.child))
        if e.parent == Root.WALL and g is not None and g.parent == Root.WALL and e.wall_id is not None:
            have = None if g.wall_id is None else wall_map.get(int(g.wall_id))
            if have != int(e.wall_id):
                label = capture.instance(int(e.child)).label
                out.append(f"{label}#{int(e.child)}: want wall {e.wall_id}, got {have} (shell wall {g.wall_id})")
    return out


def _errors(edges, gt_graph, object_of, capture) -> list[str]:
    """Human-readable list of the wrong edges of a variant."""
    out = []
    for e in gt_graph.edges:
        got = edges.get(int(e.child))
        label = capture.instance(int(e.child)).label

        def name(p):
            return p.value if isinstance(p, Root) else f"{capture.instance(int(p)).label}#{int(p)}"

        want = f"{e.relation.value} {name(e.parent)}"
        have = "none" if got is None else f"{got[0].value} {name(got[1])}"
        ok = (
            got is not None
            and got[0] == e.relation
            and (
                got[1] == e.parent
                if isinstance(e.parent, Root)
                else not isinstance(got[1], Root) and object_of.get(int(got[1])) == object_of.get(int(e.parent))
            )
        )
        if not ok:
            out.append(f"{label}#{int(e.child)}: want {want}, got {have}")
    return out


def run(seeds: list[int], preset: str, work_dir: Path) -> dict[str, Any]:
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    per_seed = [run_seed(preset, s, work_dir) for s in seeds]
    summary: dict[str, Any] = {}
    for variant in VARIANTS:
        rows = [r[variant] for r in per_seed]
        summary[variant] = {
            k: (None if rows[0][k] is None else round(sum(r[k] for r in rows) / len(rows), 4))
            for k in ("edge_accuracy", "anchor_resolved_ratio", "uncertain_ratio", "seconds")
        }
    right = sum(r["full"]["wall_id_accuracy"] * r["full"]["wall_edges"] for r in per_seed if r["full"]["wall_edges"])
    n_wall = sum(r["full"]["wall_edges"] for r in per_seed)
    summary["full"]["wall_id_accuracy"] = round(right / n_wall, 4) if n_wall else None
    summary["full"]["wall_edges"] = n_wall
    loops = [r["loopback_malformed_30"] for r in per_seed]
    summary["loopback_malformed_30"] = {
        "edge_accuracy": round(sum(r["edge_accuracy"] for r in loops) / len(loops), 4),
        "graph_valid": all(r["graph_valid"] for r in loops),
        "calls": sum(r["calls"] for r in loops),
        "malformed_answers": sum(r["malformed_answers"] for r in loops),
        "validation_retries": sum(r["validation_retries"] for r in loops),
        "frames_failed": sum(r["frame_status"]["failed"] for r in loops),
        "frames_partial": sum(r["frame_status"]["partial"] for r in loops),
    }
    return {
        "backend": "geometric (weight-free); loopback run: openai client vs a scripted endpoint, not a model",
        "summary": summary,
        "per_seed": per_seed,
    }


def table(result: dict[str, Any]) -> str:
    s = result["summary"]
    lines = [
        f"scenegraph bench, preset {result['preset']}, seeds {result['seeds']} ({result['backend']})",
        f"{'variant':<14} {'edge_acc':>9} {'anchor':>8} {'uncertain':>10} {'seconds':>8}",
    ]
    for v in VARIANTS:
        r = s[v]
        unc = "-" if r["uncertain_ratio"] is None else f"{r['uncertain_ratio']:.3f}"
        lines.append(
            f"{v:<14} {r['edge_accuracy']:>9.3f} {r['anchor_resolved_ratio']:>8.3f} {unc:>10} {r['seconds']:>8.2f}"
        )
    if s["full"].get("wall_id_accuracy") is not None:
        lines.append(
            f"full fusion wall_id accuracy {s['full']['wall_id_accuracy']:.3f} "
            f"over {s['full']['wall_edges']} wall edges hung on a wall"
        )
    lb = s["loopback_malformed_30"]
    lines.append(
        f"loopback (30% malformed JSON): edge_acc {lb['edge_accuracy']:.3f}, valid graph {lb['graph_valid']}, "
        f"{lb['calls']} calls, {lb['malformed_answers']} malformed, {lb['validation_retries']} retries, "
        f"{lb['frames_partial']} partial / {lb['frames_failed']} failed frames"
    )
    return "\n".join(lines)
