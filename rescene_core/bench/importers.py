"""Benchmark suite ``import``: importers, gravity alignment and the label-free front end.

Per seed, on a synthetic capture of the preset:
- round trip: the capture written out in the rgbd (+ instance PNGs), scannet and nerfstudio layouts and
  imported back without alignment; largest pose, intrinsics and depth differences, masks identical;
- gravity: the capture written as a y-up recorder and imported with floor alignment; floor normal error
  and camera height error against the truth;
- segmentation against the error-free object masks, both front ends: ``--segment geometric`` (label-free)
  and ``--segment masks`` on the truth's object masks damaged as a 2D segmenter's are (random ids per
  frame, splits, merges, eroded or dilated outlines, missing frames): instance recall (objects larger than
  20 cm) and precision at mask IoU 0.5, the ground-truth pairs that touch (surfaces within 3 cm) and how
  many were kept apart, seconds and frames/s. Held-out seeds (``--held-out``) run the segmentation only,
  reported in their own block.
Once, when ``../shared/data/hololens-000`` is there: the real sample imported with the label-free front
end (floor normal against the cameras' mean up, floor height, objects found, frames/s).
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.bench import seed_sets
from rescene_core.capture import open_capture
from rescene_core.capture.importers import ImportOptions, import_capture
from rescene_core.capture.importers.layouts import Y_UP_FROM_Z_UP, write_nerfstudio, write_panoptic, write_scannet
from rescene_core.capture.synth import make_scene
from rescene_core.segment import segment_geometric, segment_masks
from rescene_core.segment.damage import MaskDamage, damage_masks
from rescene_core.segment.evaluate import instance_scores, synth_object_sizes, touching_pairs

REAL_SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "hololens-000"
"""The real RGB-D recording (shared/data), relative to the repository."""


DEPTH_QUANTUM = 0.5e-3 + 1e-6
"""Largest depth difference of an exact round trip: half a millimetre of the uint16 PNG, plus float32 rounding."""


def _angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _round_trip(scene, work: Path) -> dict[str, Any]:

    a = scene.arrays
    out: dict[str, Any] = {}
    for layout in ("panoptic", "scannet", "nerfstudio"):
        src = work / f"src_{layout}"
        if layout == "panoptic":
            write_panoptic(a, src)
            fmt = "panoptic"
        elif layout == "scannet":
            write_scannet(a, src)
            fmt = "scannet"
        else:
            write_nerfstudio(a, src)
            shutil.copytree(work / "src_panoptic" / "instances", src / "instances")
            for p in sorted((src / "instances").iterdir()):
                p.rename(p.with_name(f"frame_{int(p.stem) + 1:05d}.png"))
            shutil.copy(work / "src_panoptic" / "labels.json", src / "labels.json")
            fmt = "panoptic"
        dest = work / f"{layout}.zarr"
        report = import_capture(fmt, src, dest, ImportOptions(align="none", overwrite=True))
        cap = open_capture(dest)
        if cap.depth is None:
            raise ValueError(f"{dest}: the {layout} import wrote no depth frames")
        out[layout] = {
            "pose_max_abs": float(np.abs(cap.world_from_cam - a.world_from_cam).max()),
            "K_max_abs": float(np.abs(cap.K - a.K).max()),
            "depth_max_abs_m": float(np.abs(np.asarray(cap.depth[...]) - a.depth).max()),
            "masks_identical": bool(np.array_equal(np.asarray(cap.instance_masks[...]), a.instance_masks)),
            "frames_per_s": report["throughput_fps"],
        }
        if layout != "panoptic":  # the nerfstudio layout borrows its instance PNGs
            shutil.rmtree(src, ignore_errors=True)
    shutil.rmtree(work / "src_panoptic", ignore_errors=True)
    return out


def _gravity(scene, work: Path) -> dict[str, Any]:

    a = scene.arrays
    src = write_panoptic(a, work / "src_yup", source_from_world=Y_UP_FROM_Z_UP)
    dest = work / "yup.zarr"
    report = import_capture("panoptic", src, dest, ImportOptions(overwrite=True))
    cap = open_capture(dest)
    shutil.rmtree(src, ignore_errors=True)
    al = report["alignment"]
    return {
        "method": al["method"],
        "floor_normal_error_deg": round(_angle(al["floor_normal_source"], Y_UP_FROM_Z_UP[:3, 2]), 4),
        "camera_height_error_m": round(float(np.abs(cap.world_from_cam[:, 2, 3] - a.world_from_cam[:, 2, 3]).max()), 4),
        "floor_to_camera_up_deg": al["floor_to_camera_up_deg"],
    }


def _scored(scene, seg, seconds: float, touching: list[tuple[int, int]]) -> dict[str, Any]:
    """A segmentation's instance scores against the error-free object masks, with the touching pairs kept
    apart (both objects matched, each to its own segment) and what is still missed."""
    objects = {i for i, (_, st) in seg.labels.items() if not st}
    scores = instance_scores(seg.masks, scene.object_id_frames, objects, synth_object_sizes(scene))
    labels = {int(o.object_id): o.label for o in scene.gt.objects}
    scores["missed_large"] = [
        {"object": i, "label": labels.get(i, "?"), "best_iou": iou, "size_m": size}
        for i, iou, size in scores["missed_large"]
    ]
    matched = set(scores.pop("matched_objects"))
    apart = [(a, b) for a, b in touching if a in matched and b in matched]
    kinds = [p["kind"] for p in seg.report["planes"]]
    T = len(seg.masks)
    return {
        **scores,
        "touching_pairs": len(touching),
        "touching_pairs_apart": len(apart),
        "touching_pairs_merged": [
            f"{labels.get(a, '?')} + {labels.get(b, '?')}" for a, b in touching if (a, b) not in apart
        ],
        "walls_found": kinds.count("wall"),
        "walls_true": len(scene.gt.shell.walls),
        "ceiling_found": "ceiling" in kinds,
        "seconds": round(seconds, 2),
        "frames_per_s": round(T / seconds, 2) if seconds > 0 else None,
        "step_seconds": seg.report.get("seconds", {}),
    }


def _segmentation(scene) -> dict[str, Any]:
    """Both front ends on one synthetic capture: ``geometric`` (label-free) and ``masks`` (from the truth's
    object masks damaged as a 2D segmenter's are: ``rescene_core.segment.damage``, seeded by the scene)."""
    a = scene.arrays
    touching = touching_pairs(scene)
    t = time.perf_counter()
    geo = segment_geometric(a.rgb, a.depth, a.K, a.world_from_cam)
    geometric = _scored(scene, geo, time.perf_counter() - t, touching)
    damaged = damage_masks(scene.object_id_frames, np.random.default_rng(scene.seed), MaskDamage())
    t = time.perf_counter()
    lifted = segment_masks(a.rgb, a.depth, a.K, a.world_from_cam, damaged)
    masks = _scored(scene, lifted, time.perf_counter() - t, touching)
    masks["damage"] = MaskDamage().model_dump()
    return {"geometric": geometric, "masks": masks}


def _real_sample(work: Path) -> dict[str, Any]:

    if not (REAL_SAMPLE / "poses.txt").is_file():
        return {"skipped": f"no real sample at {REAL_SAMPLE.resolve()}"}
    dest = work / "hololens-000.zarr"
    report = import_capture("rgbd", REAL_SAMPLE.resolve(), dest, ImportOptions(segment="geometric", overwrite=True))
    cap = open_capture(dest)
    floor = [int(i.id) for i in cap.instances if i.label == "floor"]
    floor_z = float(np.median(cap.point_cloud(floor[0]).points[:, 2])) if floor else float("nan")
    return {
        "frames": report["frames"]["kept"],
        "alignment": report["alignment"]["method"],
        "floor_to_camera_up_deg": report["alignment"]["floor_to_camera_up_deg"],
        "floor_median_z_m": round(floor_z, 4),
        "objects": report["instances"]["objects"],
        "structural": report["instances"]["structural"],
        "frames_per_s": report["throughput_fps"],
        "seconds": report["timings_s"],
    }


def run(seeds: list[int], preset: str, work_dir: Path, held_out: list[int] | None = None) -> dict[str, Any]:
    """Round trips, gravity and both segmentation front ends on the development ``seeds``; the segmentation
    alone on the ``held_out`` seeds (reported in their own block, never pooled)."""
    work_dir = Path(work_dir)
    work_dir.mkdir(parents=True, exist_ok=True)
    sets = seed_sets(seeds, held_out)
    per_seed: list[dict[str, Any]] = []
    for name, seed_list in sets.items():
        for seed in seed_list:
            scene = make_scene(preset, seed)
            entry: dict[str, Any] = {"seed": seed, "set": name}
            if name == "development":
                work = work_dir / f"seed{seed}"
                work.mkdir(parents=True, exist_ok=True)
                entry["round_trip"] = _round_trip(scene, work)
                entry["gravity"] = _gravity(scene, work)
            entry["segmentation"] = _segmentation(scene)
            per_seed.append(entry)

    def mean(rows: list[dict[str, Any]], key: str) -> float | None:
        vals = [r[key] for r in rows if r[key] is not None]
        return round(float(np.mean(vals)), 4) if vals else None

    summary: dict[str, Any] = {}
    for name in sets:
        block: dict[str, Any] = {}
        for mode in ("geometric", "masks"):
            rows = [s["segmentation"][mode] for s in per_seed if s["set"] == name]
            block[mode] = {
                "recall_large": mean(rows, "recall_large"),
                "recall_all": mean(rows, "recall_all"),
                "precision": mean(rows, "precision"),
                "seconds": mean(rows, "seconds"),
                "touching_pairs": sum(r["touching_pairs"] for r in rows),
                "touching_pairs_apart": sum(r["touching_pairs_apart"] for r in rows),
            }
        summary[name] = block
    dev = [s for s in per_seed if s["set"] == "development"]
    summary["floor_normal_error_deg_max"] = max(s["gravity"]["floor_normal_error_deg"] for s in dev) if dev else None
    summary["round_trip_exact"] = all(
        r["masks_identical"]
        and r["pose_max_abs"] < 1e-9
        and r["K_max_abs"] < 1e-9
        and r["depth_max_abs_m"] <= DEPTH_QUANTUM
        for s in dev
        for r in s["round_trip"].values()
    )
    return {"per_seed": per_seed, "summary": summary, "real_sample": _real_sample(work_dir)}


def table(result: dict[str, Any]) -> str:
    lines = [f"import suite, preset {result['preset']}, seeds {result['seeds']}"]
    lines.append("round trip (align none): layout | pose max | K max | depth max (m) | masks identical | frames/s")
    for s in result["per_seed"]:
        for layout, r in s.get("round_trip", {}).items():
            lines.append(
                f"  seed {s['seed']} {layout:10s} | {r['pose_max_abs']:.1e} | {r['K_max_abs']:.1e} | "
                f"{r['depth_max_abs_m']:.1e} | {r['masks_identical']} | {r['frames_per_s']:.1f}"
            )
    lines.append("gravity (y-up recorder): seed | floor normal error (deg) | camera height error (m)")
    for s in result["per_seed"]:
        if "gravity" in s:
            g = s["gravity"]
            lines.append(f"  {s['seed']} | {g['floor_normal_error_deg']:.3f} | {g['camera_height_error_m']:.3f}")
    lines.append(
        "segmentation: set | seed | mode | recall >20 cm | recall all | precision | segments | touching pairs apart | "
        "walls | s | frames/s"
    )
    for s in result["per_seed"]:
        for mode in ("geometric", "masks"):
            g = s["segmentation"][mode]
            lines.append(
                f"  {s['set']} | {s['seed']} | {mode} | {g['recall_large']} | {g['recall_all']} | {g['precision']} | "
                f"{g['segments']} | {g['touching_pairs_apart']}/{g['touching_pairs']} | "
                f"{g['walls_found']}/{g['walls_true']} | {g['seconds']} | {g['frames_per_s']}"
            )
    sm = result["summary"]
    for name in ("development", "held_out"):
        if name not in sm:
            continue
        for mode in ("geometric", "masks"):
            b = sm[name][mode]
            aim = "0.85" if mode == "geometric" else "0.9"
            lines.append(
                f"{name} {mode}: mean recall >20 cm {b['recall_large']}, precision {b['precision']} (aim {aim} both), "
                f"touching pairs apart {b['touching_pairs_apart']}/{b['touching_pairs']}, {b['seconds']} s per scene"
            )
    r = result["real_sample"]
    if "skipped" in r:
        lines.append(f"real sample: {r['skipped']}")
    else:
        lines.append(
            f"real sample: {r['frames']} frames, floor {r['floor_to_camera_up_deg']:.2f} deg from the cameras' up, "
            f"floor median z {r['floor_median_z_m'] * 100:.1f} cm, {r['objects']} objects, {r['frames_per_s']:.2f} frames/s"
        )
    return "\n".join(lines)
