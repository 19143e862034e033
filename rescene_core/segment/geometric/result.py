"""The segmenter's result: the labelled mesh rendered into every frame, labels and the report."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.render.raycast import RayCaster
from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.points import ScanPoints
from rescene_core.segment.labels import zero_shot_labels
from rescene_core.segment.project import fill_from_surface, labelled_meshes, render_masks


@dataclass
class SegmentResult:
    """Masks int32 [T, H, W] (0 = none), labels {id: (label, structural)}, the segmenter's name and a report."""

    masks: NDArray[np.int32]
    labels: dict[int, tuple[str, bool]]
    segmenter: str
    report: dict[str, Any] = field(default_factory=dict)
    mesh_vertices: NDArray[np.float64] | None = None
    mesh_faces: NDArray[np.int64] | None = None
    face_labels: NDArray[np.int64] | None = None


def _finish(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    verts: NDArray,
    faces: NDArray[np.int64],
    struct: NDArray[np.int64],
    planes: list[dict[str, Any]],
    sp: ScanPoints,
    region: NDArray[np.int64],
    cfg: SegmentConfig,
    segmenter: str,
    stats: dict[str, Any],
    clip_model: str | None,
    clip_model_name: str,
    vocabulary: tuple[str, ...],
) -> SegmentResult:
    """Vertex labels from the structure and the object regions, rendered into every frame; labels; report."""
    T, H, W = depth.shape
    n_struct = max(int(p["id"]) for p in planes)
    vregion = np.zeros(len(verts), np.int64)
    mapped = sp.vertex_point >= 0
    vregion[mapped] = region[sp.graph.label[sp.vertex_point[mapped]]]
    vlabel = np.where(vregion > 0, vregion + n_struct, struct)
    # a face takes the label two or three of its vertices share, else none
    fl = vlabel[faces]
    face_label = np.where(
        (fl[:, 0] == fl[:, 1]) | (fl[:, 0] == fl[:, 2]), fl[:, 0], np.where(fl[:, 1] == fl[:, 2], fl[:, 1], 0)
    )
    caster = RayCaster(labelled_meshes(verts, faces, face_label))
    masks, rstats = render_masks(
        caster, K, world_from_cam, W, H, depth, cfg.depth_abs_tolerance, cfg.depth_rel_tolerance
    )
    if cfg.fill_radius > 0:
        rstats["filled_from_surface"] = fill_from_surface(
            masks, depth, K, world_from_cam, verts, vlabel, cfg.fill_radius
        )
    counts = np.bincount((masks.reshape(T, -1).astype(np.int64) + np.arange(T)[:, None] * (int(masks.max()) + 1)).ravel(),
                         minlength=T * (int(masks.max()) + 1)).reshape(T, -1)  # fmt: skip
    small = (counts > 0) & (counts < cfg.min_mask_pixels)
    small[:, 0] = False
    if small.any():
        masks[np.take_along_axis(small, masks.reshape(T, -1).astype(np.int64), axis=1).reshape(masks.shape)] = 0
    present = {int(i) for i in np.flatnonzero(np.bincount(masks.ravel())) if i > 0}
    kinds = {p["id"]: p["kind"] for p in planes}
    labels: dict[int, tuple[str, bool]] = {}
    for i in sorted(present):
        labels[i] = (kinds[i], True) if i in kinds else ("object", False)
    objects = [i for i in labels if not labels[i][1]]
    if not objects:
        raise SegmentError(
            f"empty scene after segmentation: {stats.get('superpoints', 0)} superpoints, none kept in an object "
            f"({stats.get('too_small', 0)} regions smaller than {cfg.min_segment_extent} m or {cfg.min_segment_points} "
            f"points, {stats.get('too_large', 0)} larger than {cfg.max_segment_extent} m); the recording may not show "
            "objects clear of the floor and walls"
        )
    label_report: dict[str, Any] = {"labeller": "none (every segment is 'object')"}
    if clip_model:
        names, label_report = zero_shot_labels(
            rgb, masks, objects, clip_model, clip_model_name, vocabulary, cfg.clip_views
        )
        for i, name in names.items():
            labels[i] = (name, False)
        segmenter += "+clip"
    report = {
        "segmenter": segmenter,
        "mesh": {"vertices": int(len(verts)), "faces": int(len(faces)), "tsdf_voxel": cfg.tsdf_voxel},
        "planes": planes,
        "regions": stats,
        "render": rstats,
        "objects": len(objects),
        "structural": len(labels) - len(objects),
        "labels": label_report,
        "config": cfg.model_dump(mode="json"),
    }
    return SegmentResult(masks, labels, segmenter, report, verts, faces, face_label)
