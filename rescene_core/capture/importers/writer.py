"""The shared end of every importer: align, segment (when asked), fuse instance clouds, write the capture
atomically, validate it before it is moved into place, and write the import report beside it.

``OUT.zarr`` is either a complete, valid capture or absent (a failed import leaves what was there before);
the report is ``OUT_import.json`` next to it and a copy sits in the capture's ``import`` attribute.
"""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture.align import (
    AlignConfig,
    apply_alignment,
    estimate_alignment,
    identity_alignment,
    transform_points,
)
from rescene_core.capture.depth_points import DepthPointsConfig, instance_points, scene_points
from rescene_core.capture.format import (
    CaptureArrays,
    FrameData,
    FrameMap,
    iter_slabs,
    points_to_csr,
    write_capture,
)
from rescene_core.capture.importers.common import (
    ImportInputError,
    ImportOptions,
    SourceFrames,
    is_structural,
    mask_id_counts,
    read_source_gravity,
)
from rescene_core.capture.validate import check_capture
from rescene_core.io import atomic_directory, write_json_atomic
from rescene_core.records import Instance, InstanceId
from rescene_core.segment import SegmentError, segment_geometric, segment_masks
from rescene_core.segment.lift import read_mask_dir


def report_path(out: str | Path) -> Path:
    """Where the import report of the capture at ``out`` goes: ``room.zarr`` -> ``room_import.json``."""
    p = Path(out)
    stem = p.name[: -len(".zarr")] if p.name.endswith(".zarr") else p.name
    return p.parent / f"{stem}_import.json"


def _depth_stats(depth: np.ndarray | FrameData | None) -> dict[str, Any]:
    """Valid-depth coverage per frame (mean, least) and the median valid depth of every 4th pixel in both
    directions (m), read a slab of frames at a time."""
    if depth is None:
        return {"present": False}
    per_frame: list[np.ndarray] = []
    samples: list[np.ndarray] = []
    for _, slab in iter_slabs(depth):
        per_frame.append((slab > 0).reshape(len(slab), -1).mean(axis=1))
        sample = slab[:, ::4, ::4]
        samples.append(sample[sample > 0])
    coverage = np.concatenate(per_frame)
    valid = np.concatenate(samples)
    return {
        "present": True,
        "coverage_mean": round(float(coverage.mean()), 4),
        "coverage_min": round(float(coverage.min()), 4),
        "median_m": round(float(np.median(valid)), 4) if len(valid) else 0.0,
    }


def finish_import(
    frames: SourceFrames,
    out: str | Path,
    opts: ImportOptions,
    started: float,
    align_config: AlignConfig | None = None,
    points_config: DepthPointsConfig | None = None,
    segment_config: Any = None,
    mask_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Turn read frames into a capture at ``out``; returns the import report (also written beside it).

    mask_dir: with ``--segment masks``, the folder of per-frame id PNGs of a 2D segmenter (named like the
    frames' images; ids need not agree across frames)."""
    out = Path(out)
    timings: dict[str, float] = {"read": time.perf_counter() - started}
    if out.exists() and not opts.overwrite:
        raise FileExistsError(f"{out} exists; pass --overwrite or choose another path")
    if frames.depth is None:
        raise ImportInputError(
            f"{frames.src}: the source has no depth; instance point clouds and the floor need metric depth "
            "(fix: add depth maps, e.g. depth_file_path in transforms.json)"
        )
    T = len(frames.names)
    if mask_dir is not None and opts.segment != "masks":
        raise ImportInputError(
            f"{frames.src}: --masks {mask_dir} is read with --segment masks (or the panoptic format, whose masks are "
            "consistent instance ids); add --segment masks"
        )
    if opts.segment == "masks" and mask_dir is None:
        raise ImportInputError(
            f"{frames.src}: --segment masks needs --masks DIR, a folder with one id PNG per frame named like the "
            "frame's image (e.g. SAM 2 automatic masks; docs/importing.md shows how to make them)"
        )
    if T == 1 and opts.segment in ("geometric", "masks"):
        raise ImportInputError(
            f"{frames.src}: a single frame ({frames.names[0]}) to import; --segment {opts.segment} keeps only the surface "
            "seen from two frames or more, so one frame gives none (fix: import more frames, check --stride and "
            "--max-frames, or give per-frame instance masks with the panoptic format)"
        )
    if T == 1:
        frames.notes.append(f"a single frame ({frames.names[0]}): the floor and the instance clouds come from one view")

    t = time.perf_counter()
    if opts.align == "floor":
        up, gravity_from = _source_up(frames, opts)
        cfg = align_config or AlignConfig()
        if opts.max_tilt is not None:
            cfg = cfg.model_copy(update={"gravity_max_tilt_deg" if up is not None else "max_tilt_deg": opts.max_tilt})
        fused = scene_points(frames.depth, frames.K, frames.world_from_cam)
        try:
            alignment = estimate_alignment(fused, frames.world_from_cam, cfg, up=up, gravity_from=gravity_from)
        except ValueError as err:
            raise ImportInputError(
                f"{frames.src}: cannot find gravity ({err}); pass --up X,Y,Z (the source's up) or --align none"
            ) from err
    else:
        if opts.up is not None or opts.max_tilt is not None:
            raise ImportInputError(
                f"{frames.src}: --up and --max-tilt need --align floor (--align none keeps the frame)"
            )
        alignment = identity_alignment(frames.world_from_cam)
    world_from_cam = apply_alignment(alignment, frames.world_from_cam)
    timings["align"] = time.perf_counter() - t

    t = time.perf_counter()
    segment_report: dict[str, Any]
    labels = dict(frames.labels)
    if frames.render_masks is not None and opts.segment == "none":
        frames.render_masks(frames)
    if opts.segment in ("geometric", "masks"):
        # the segmenters take whole arrays: the frames are read into memory for them (only here)
        rgb_all, depth_all = np.asarray(frames.rgb), np.asarray(frames.depth)
        try:
            if opts.segment == "masks":
                H, W = frames.depth.shape[1:]
                frame_masks = read_mask_dir(mask_dir or "", frames.names, H, W)
                missing = sum(m is None for m in frame_masks)
                if missing:
                    frames.notes.append(f"{missing} of {T} frames have no mask in {mask_dir}: they cast no votes")
                seg = segment_masks(
                    rgb_all, depth_all, frames.K, world_from_cam, frame_masks, segment_config,
                    opts.clip_model, opts.clip_model_name, opts.vocabulary,
                )  # fmt: skip
            else:
                seg = segment_geometric(
                    rgb_all, depth_all, frames.K, world_from_cam, segment_config, opts.clip_model,
                    opts.clip_model_name, opts.vocabulary,
                )  # fmt: skip
        except SegmentError as err:
            raise ImportInputError(f"{frames.src}: {err}") from err
        del rgb_all, depth_all
        if frames.masks is not None:
            frames.notes.append(
                f"the source's masks were replaced by the {opts.segment} segmentation (--segment {opts.segment})"
            )
        masks = seg.masks
        labels = {i: (lab, st) for i, (lab, st) in seg.labels.items()}
        segmenter = seg.segmenter
        segment_report = seg.report
    elif frames.masks is not None:
        masks = frames.masks
        segmenter = frames.source + "-masks"
        segment_report = {"segmenter": segmenter}
    else:
        raise ImportInputError(
            f"{frames.src}: the source has no instance masks (fix: pass --segment geometric for label-free "
            "instances, --segment masks --masks DIR for a 2D segmenter's per-frame masks, or import with the "
            "panoptic format and a folder of instance PNGs)"
        )
    timings["segment"] = time.perf_counter() - t

    counts = mask_id_counts(masks, frames.src)
    if isinstance(masks, np.ndarray):
        masks = masks.astype(np.int32, copy=False)  # the masks of a long scan are not copied
    present = [int(i) for i in np.flatnonzero(counts) if i > 0]
    structural = {i for i in present if labels.get(i, ("object", False))[1]}

    t = time.perf_counter()
    clouds, point_stats = instance_points(
        frames.depth, masks, frames.rgb, frames.K, world_from_cam, structural, points_config
    )
    timings["points"] = time.perf_counter() - t
    cfg_points = points_config or DepthPointsConfig()
    masks, dropped_instances = _drop_objects_without_points(
        masks, counts, present, structural, clouds, labels, cfg_points
    )
    kept_ids = [i for i in present if i not in {d["id"] for d in dropped_instances}]
    if dropped_instances:
        frames.notes.append(
            f"{len(dropped_instances)} object instances dropped, no depth points: ids "
            f"{[d['id'] for d in dropped_instances]} (fewer than {cfg_points.min_points} fused points each; "
            "their mask pixels are cleared)"
        )
    instances = [Instance(InstanceId(i), labels.get(i, ("object", False))[0], i in structural) for i in kept_ids]
    objects_with_points = [i for i in kept_ids if i not in structural and i in clouds]
    if not objects_with_points:
        raise ImportInputError(
            f"{frames.src}: empty scene: no object instance has depth points after {segmenter} "
            f"({len(present)} ids in the masks, {len(structural)} structural); check the masks and depth, "
            "or lower the segmenter's minimum size"
        )
    point_ids, offsets, points, colors = points_to_csr(clouds)
    depth_stats = _depth_stats(frames.depth)
    reasons = Counter(d.reason.split(":")[0] for d in frames.dropped)
    report: dict[str, Any] = {
        "format": frames.source,
        "src": str(frames.src),
        "out": str(out),
        "scene_id": opts.scene_id or frames.src.name,
        "segmenter": segmenter,
        "frames": {
            "in_source": int(frames.frames_in_source),
            "kept": T,
            "dropped": len(frames.dropped),
            "dropped_by_reason": dict(sorted(reasons.items())),
            "dropped_frames": [d.to_json() for d in frames.dropped],
            "stride": opts.stride,
        },
        "image_size": [int(frames.rgb.shape[2]), int(frames.rgb.shape[1])],  # (W, H)
        "depth": depth_stats,
        "instances": {
            "total": len(instances),
            "objects": sum(1 for i in instances if not i.structural),
            "structural": len(structural),
            "objects_with_points": len(objects_with_points),
            "dropped": len(dropped_instances),
            "dropped_by_reason": dict(sorted(Counter(d["reason"] for d in dropped_instances).items())),
            "dropped_instances": dropped_instances,
            "labels": dict(sorted(Counter(i.label for i in instances).items())),
        },
        "points": {"total": int(len(points)), **point_stats},
        "alignment": alignment.to_json(),
        "warnings": [alignment.warning] if alignment.warning else [],
        "segmentation": segment_report,
        "notes": list(frames.notes),
    }
    source = f"{frames.source}+{segmenter}" if not segmenter.startswith(frames.source) else segmenter
    arrays = CaptureArrays(
        scene_id=report["scene_id"],
        rgb=frames.rgb,
        K=frames.K.astype(np.float64),
        world_from_cam=world_from_cam,
        instance_masks=masks,
        instances=tuple(instances),
        point_ids=point_ids,
        point_offsets=offsets,
        points=points,
        colors=colors,
        depth=frames.depth,
        source=source,
        extra_attrs={
            "alignment": alignment.to_json(),
            "import": {k: v for k, v in report.items() if k not in ("segmentation",)} | {"frame_names": frames.names},
        },
    )
    t = time.perf_counter()
    write_validated(out, arrays)
    if frames.store is not None:
        frames.store.close()  # the capture holds the frames now
    timings["write"] = time.perf_counter() - t
    elapsed = time.perf_counter() - started
    report["timings_s"] = {k: round(v, 3) for k, v in timings.items()} | {"total": round(elapsed, 3)}
    report["throughput_fps"] = round(T / max(elapsed, 1e-9), 3)
    write_json_atomic(report_path(out), report)
    return report


def _source_up(frames: SourceFrames, opts: ImportOptions) -> tuple[np.ndarray | None, str]:
    """The recorder's up in the source frame and where it came from: ``--up``, else the source's own gravity
    file, else (None, '') and the floor search works from the cameras alone."""
    found = read_source_gravity(frames.src)
    if opts.up is not None:
        if found is not None:
            frames.notes.append(f"--up {list(opts.up)} is used; the source's own gravity in {found[1]} is not")
        return np.asarray(opts.up, np.float64), "--up"
    if found is not None:
        frames.notes.append(f"gravity read from {found[1]}: up {np.round(found[0], 4).tolist()} in the source frame")
        return found
    return None, ""


def _drop_objects_without_points(
    masks: np.ndarray | FrameData,
    pixel_counts: np.ndarray,
    present: list[int],
    structural: set[int],
    clouds: dict[int, Any],
    labels: dict[int, tuple[str, bool]],
    cfg: DepthPointsConfig,
) -> tuple[np.ndarray | FrameData, list[dict[str, Any]]]:
    """Object ids of the masks that fused no cloud leave the capture: their pixels become 0 (no instance)
    and each is listed with its label, mask pixels and reason. A segment or panoptic mask can be too small
    or too thin to keep ``min_points`` points once it is eroded, cleared of depth edges and voxel-thinned;
    written without points it would reach every later stage as an object with nothing to register.
    Structural ids keep their records (the room shell is fitted from the whole depth). The masks come back
    as a ``FrameMap`` that clears those ids as it is read."""
    empty = [i for i in present if i not in structural and i not in clouds]
    if not empty:
        return masks, []
    gone = np.asarray(empty, np.int32)

    def clear(slab: np.ndarray) -> np.ndarray:
        return np.where(np.isin(slab, gone), np.int32(0), slab).astype(np.int32, copy=False)

    # the cleared masks are made as the writer reads them, a slab at a time (no copy of every frame)
    masks = FrameMap(masks, clear, np.int32)
    dropped = [
        {
            "id": i,
            "label": labels.get(i, ("object", False))[0],
            "mask_pixels": int(pixel_counts[i]),
            "reason": "no depth points",
            "detail": (
                f"fewer than {cfg.min_points} fused points after {cfg.erode_px} px erosion, depth-edge removal, "
                f"{cfg.object_voxel} m voxels and outlier removal"
            ),
        }
        for i in empty
    ]
    return masks, dropped


def write_validated(out: Path, arrays: CaptureArrays) -> Path:
    """Write the capture into a temporary sibling, validate it there, then move it into place."""
    with atomic_directory(out) as tmp:
        write_capture(tmp, arrays, overwrite=True)
        errors = [p for p in check_capture(tmp) if p.severity == "error"]
        if errors:
            lines = "; ".join(str(p) for p in errors[:5])
            raise ImportInputError(f"{out}: the imported capture does not validate ({lines})")
    return out


def aligned_points(alignment_json: dict[str, Any], points: np.ndarray) -> np.ndarray:
    """Source-frame points [n, 3] in a capture's aligned frame (its ``alignment`` attribute)."""
    return transform_points(np.asarray(alignment_json["aligned_from_source"]), points)


def labels_from_json(data: Any, where: Path) -> dict[int, tuple[str, bool]]:
    """A labels file: {"id": "label"}, {"id": {"label", "structural"}} or [{"id", "label", "structural"}]."""
    out: dict[int, tuple[str, bool]] = {}
    items: list[tuple[Any, Any]]
    if isinstance(data, dict):
        items = list(data.items())
    elif isinstance(data, list):
        items = [(d.get("id"), d) if isinstance(d, dict) else (None, d) for d in data]
    else:
        raise ImportInputError(f"{where}: expected an object {{id: label}} or a list of {{id, label}} records")
    for key, val in items:
        try:
            iid = int(key)
        except (TypeError, ValueError):
            raise ImportInputError(f"{where}: instance id {key!r} is not an integer") from None
        if iid <= 0:
            raise ImportInputError(f"{where}: instance id {iid} must be positive (0 means 'no instance')")
        if isinstance(val, str):
            label, structural = val, is_structural(val)
        elif isinstance(val, dict) and isinstance(val.get("label"), str):
            label = val["label"]
            structural = bool(val.get("structural", is_structural(label)))
        else:
            raise ImportInputError(f"{where}: instance {iid} has no label string ({val!r})")
        if not label.strip():
            raise ImportInputError(f"{where}: instance {iid} has an empty label")
        out[iid] = (label.strip(), structural)
    return out
