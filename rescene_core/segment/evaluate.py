"""Label-free segmentation against synthetic ground truth: instance recall and precision at a mask IoU.

IoU of a predicted segment and a ground-truth object is taken over all frames at once (pixels summed
over the capture), so an object is one instance across views, as the capture format asks. Each ground
truth object is matched to at most one segment (greedy by IoU, best first).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray


def mask_iou_table(pred: NDArray[np.int32], gt: NDArray[np.int32]) -> tuple[NDArray, NDArray, NDArray]:
    """IoU [G, P] between every ground-truth id and every predicted id over all frames, with the ids
    (0 excluded on both sides). pred, gt: int [T, H, W]."""
    p = np.asarray(pred, np.int64).ravel()
    g = np.asarray(gt, np.int64).ravel()
    ng, np_ = int(g.max(initial=0)) + 1, int(p.max(initial=0)) + 1
    full = np.bincount(g * np_ + p, minlength=ng * np_).reshape(ng, np_)
    gids, pids = np.flatnonzero(full.sum(axis=1)), np.flatnonzero(full.sum(axis=0))
    joint = full[np.ix_(gids, pids)]
    gsum, psum = joint.sum(axis=1), joint.sum(axis=0)
    union = gsum[:, None] + psum[None, :] - joint
    iou = joint / np.maximum(union, 1)
    gk, pk = gids > 0, pids > 0
    return iou[np.ix_(gk, pk)], gids[gk], pids[pk]


def instance_scores(
    pred: NDArray[np.int32],
    gt: NDArray[np.int32],
    pred_objects: set[int],
    gt_sizes: dict[int, float],
    iou_threshold: float = 0.5,
    min_size: float = 0.2,
) -> dict[str, Any]:
    """Recall (ground-truth objects larger than ``min_size`` m that some segment covers at IoU >=
    ``iou_threshold``), recall over all visible objects, and precision (object segments matched).

    pred_objects: the non-structural predicted ids. gt_sizes: object id -> largest dimension (m).
    """
    pred = np.where(np.isin(pred, list(pred_objects)), pred, 0)
    iou, gids, pids = mask_iou_table(pred, gt)
    pairs = sorted(((iou[a, b], a, b) for a, b in zip(*np.nonzero(iou >= iou_threshold))), reverse=True)
    used_g, used_p, matched = set(), set(), {}
    for v, a, b in pairs:
        if a in used_g or b in used_p:
            continue
        used_g.add(a)
        used_p.add(b)
        matched[int(gids[a])] = (int(pids[b]), float(v))
    visible = [int(i) for i in gids]
    large = [i for i in visible if gt_sizes.get(i, 0.0) > min_size]
    n_pred = len([i for i in pids if int(i) in pred_objects])
    best = {int(gids[a]): float(iou[a].max()) if iou.shape[1] else 0.0 for a in range(len(gids))}
    return {
        "gt_objects_visible": len(visible),
        "gt_objects_large": len(large),
        "segments": n_pred,
        "matched": len(matched),
        "recall_large": round(sum(i in matched for i in large) / len(large), 4) if large else None,
        "recall_all": round(len(matched) / len(visible), 4) if visible else None,
        "precision": round(len(matched) / n_pred, 4) if n_pred else None,
        "iou_threshold": iou_threshold,
        "min_size_m": min_size,
        "matched_objects": sorted(matched),
        "missed_large": sorted(
            (i, round(best[i], 3), round(gt_sizes.get(i, 0.0), 3)) for i in large if i not in matched
        ),
    }


def synth_object_sizes(scene) -> dict[int, float]:
    """Largest dimension (m) of each ground-truth object of a synthetic scene."""
    out = {}
    for o in scene.gt.objects:
        out[int(o.object_id)] = float(np.ptp(np.asarray(o.vertices), axis=0).max())
    return out


def touching_pairs(scene, gap: float = 0.03, samples: int = 3000, seed: int = 0) -> list[tuple[int, int]]:
    """Ground-truth object pairs (ids, a < b) whose surfaces come closer than ``gap`` metres: a lamp on a
    nightstand, a chair pushed against a table. Each mesh is sampled at ``samples`` points (trimesh)."""
    import trimesh
    from scipy.spatial import cKDTree

    clouds = {}
    for o in scene.gt.objects:
        mesh = trimesh.Trimesh(np.asarray(o.vertices), np.asarray(o.faces), process=False)
        pts = np.asarray(trimesh.sample.sample_surface(mesh, samples, seed=seed)[0])
        pose = np.asarray(o.world_from_object)
        clouds[int(o.object_id)] = pts @ pose[:3, :3].T + pose[:3, 3]
    ids = sorted(clouds)
    trees = {i: cKDTree(clouds[i]) for i in ids}
    lo = {i: clouds[i].min(axis=0) for i in ids}
    hi = {i: clouds[i].max(axis=0) for i in ids}
    out = []
    for k, a in enumerate(ids):
        for b in ids[k + 1 :]:
            if np.any(lo[a] - gap > hi[b]) or np.any(lo[b] - gap > hi[a]):
                continue
            d, _ = trees[b].query(clouds[a], k=1, distance_upper_bound=gap)
            if np.isfinite(d).any():
                out.append((a, b))
    return out
