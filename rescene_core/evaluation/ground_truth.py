"""Metrics of an assembled scene against the capture's ground truth (synthetic captures).

- per object: distance between the world bounding-box centres of the placed mesh and of the GT mesh (m),
  relative error of the bounding-box diagonal, and the symmetric chamfer distance of the two surfaces
  (mean nearest-neighbour distance of surface samples, m), for the registered and the attached pose;
- scene: symmetric chamfer distance between all placed meshes and all GT object meshes (m);
- graph: accuracy of the predicted edge (relation and parent) of every GT edge, over instance ids mapped
  to objects, plus the precision of the predicted edges.
Frames: world metres. Objects are matched through ``GroundTruth.object_of_instance``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict
from scipy.spatial import cKDTree

from rescene_core.capture.ground_truth import GroundTruth
from rescene_core.records import Root, SceneGraph


class GtEvaluationConfig(BaseModel):
    """Sampling of the chamfer distances."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    object_samples: int = 2000
    """Surface points sampled per object mesh for the per-object chamfer distance."""
    scene_samples: int = 20000
    """Surface points sampled on each whole scene (placed / GT) for the scene chamfer distance."""
    seed: int = 0
    """Seed of the surface sampling."""


def _sample(mesh: trimesh.Trimesh, n: int, seed: int) -> NDArray[np.float64]:
    if len(mesh.faces) == 0 or mesh.area <= 0:
        return np.asarray(mesh.vertices, dtype=np.float64)
    points, _ = trimesh.sample.sample_surface(mesh, n, seed=seed)
    return np.asarray(points, dtype=np.float64)


def chamfer(a: NDArray, b: NDArray) -> float:
    """Symmetric chamfer distance (m): mean of the two mean nearest-neighbour distances between point sets."""
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    d_ab, _ = cKDTree(b).query(a)
    d_ba, _ = cKDTree(a).query(b)
    return float((d_ab.mean() + d_ba.mean()) / 2)


def _placed(vertices: NDArray, faces: NDArray, world_from_asset: NDArray) -> trimesh.Trimesh:
    m = np.asarray(world_from_asset, dtype=np.float64)
    return trimesh.Trimesh(np.asarray(vertices) @ m[:3, :3].T + m[:3, 3], np.asarray(faces), process=False)


def object_errors(pred: trimesh.Trimesh, gt: trimesh.Trimesh, config: GtEvaluationConfig) -> dict[str, float]:
    """Centre distance (m), relative diagonal error and chamfer distance (m) of one placed mesh vs its GT."""
    lo_p, hi_p = pred.bounds
    lo_g, hi_g = gt.bounds
    diag_p, diag_g = float(np.linalg.norm(hi_p - lo_p)), float(np.linalg.norm(hi_g - lo_g))
    return {
        "centre_error": float(np.linalg.norm((lo_p + hi_p) / 2 - (lo_g + hi_g) / 2)),
        "size_error": abs(diag_p - diag_g) / diag_g if diag_g > 0 else float("nan"),
        "chamfer": chamfer(
            _sample(pred, config.object_samples, config.seed), _sample(gt, config.object_samples, config.seed)
        ),
    }


def graph_accuracy(pred: SceneGraph, gt: GroundTruth) -> dict[str, Any]:
    """Edge accuracy of ``pred`` against the GT relations, comparing parents as objects (or roots)."""
    obj_of = gt.object_of_instance()
    gt_graph = gt.graph_by_instance()

    def parent_key(parent):
        return parent.value if isinstance(parent, Root) else obj_of.get(int(parent), -int(parent))

    pred_by_object = {}
    for e in pred.edges:
        if int(e.child) in obj_of:
            pred_by_object.setdefault(obj_of[int(e.child)], e)
    correct = relation_ok = parent_ok = 0
    gt_keys = {}
    for e in gt_graph.edges:
        child = obj_of[int(e.child)]
        gt_keys[child] = (e.relation, parent_key(e.parent))
        p = pred_by_object.get(child)
        if p is None:
            continue
        r_ok = p.relation == e.relation
        pa_ok = parent_key(p.parent) == parent_key(e.parent)
        relation_ok += r_ok
        parent_ok += pa_ok
        correct += r_ok and pa_ok
    n_gt = len(gt_graph.edges)
    predicted_matching = sum(
        1 for child, p in pred_by_object.items() if gt_keys.get(child) == (p.relation, parent_key(p.parent))
    )
    return {
        "gt_edges": n_gt,
        "predicted_edges": len(pred.edges),
        "edge_accuracy": correct / n_gt if n_gt else None,
        "relation_accuracy": relation_ok / n_gt if n_gt else None,
        "parent_accuracy": parent_ok / n_gt if n_gt else None,
        "edge_precision": predicted_matching / len(pred.edges) if pred.edges else None,
    }


def gt_metrics(
    objects: Mapping[int, tuple[str, NDArray, NDArray]],
    final_poses: Mapping[int, NDArray],
    registered_poses: Mapping[int, NDArray],
    graph: SceneGraph,
    gt: GroundTruth,
    config: GtEvaluationConfig | None = None,
) -> dict[str, Any]:
    """Metrics of placed objects against ``gt``.

    objects: instance id -> (label, vertices [v, 3] asset frame, faces [f, 3]).
    final_poses / registered_poses: instance id -> world_from_asset float64 [4, 4].
    """
    config = config or GtEvaluationConfig()
    obj_of = gt.object_of_instance()
    per_object = []
    placed_meshes = []
    for i in sorted(objects):
        label, verts, faces = objects[i]
        final = _placed(verts, faces, final_poses.get(i, registered_poses.get(i)))
        placed_meshes.append(final)
        if i not in obj_of:
            per_object.append({"instance": int(i), "label": label, "object_id": None})
            continue
        gt_mesh = gt.world_mesh(obj_of[i])
        row = {"instance": int(i), "label": label, "object_id": int(obj_of[i])}
        row.update({f"final_{k}": v for k, v in object_errors(final, gt_mesh, config).items()})
        if i in registered_poses:
            reg = _placed(verts, faces, registered_poses[i])
            row.update({f"registered_{k}": v for k, v in object_errors(reg, gt_mesh, config).items()})
        per_object.append(row)
    matched = [r for r in per_object if r["object_id"] is not None]
    gt_all = trimesh.util.concatenate([gt.world_mesh(o.object_id) for o in gt.objects]) if gt.objects else None
    pred_all = trimesh.util.concatenate(placed_meshes) if placed_meshes else None
    scene_chamfer = (
        chamfer(
            _sample(pred_all, config.scene_samples, config.seed), _sample(gt_all, config.scene_samples, config.seed)
        )
        if gt_all is not None and pred_all is not None
        else None
    )
    found = {obj_of[i] for i in objects if i in obj_of}

    def mean(key: str) -> float | None:
        vals = [r[key] for r in matched if r.get(key) is not None and np.isfinite(r[key])]
        return float(np.mean(vals)) if vals else None

    return {
        "objects_gt": len(gt.objects),
        "objects_placed": len(objects),
        "objects_recalled": len(found),
        "recall": len(found) / len(gt.objects) if gt.objects else None,
        "scene_chamfer": scene_chamfer,
        "mean_final_centre_error": mean("final_centre_error"),
        "mean_final_chamfer": mean("final_chamfer"),
        "mean_final_size_error": mean("final_size_error"),
        "mean_registered_centre_error": mean("registered_centre_error"),
        "mean_registered_chamfer": mean("registered_chamfer"),
        "graph": graph_accuracy(graph, gt),
        "per_object": per_object,
    }
