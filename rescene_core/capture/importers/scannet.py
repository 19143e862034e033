"""ScanNet scenes as ScanNet's reader exports them (``reader.py --export_color_images --export_depth_images
--export_poses --export_intrinsics``), with instance masks from the 2D annotation export or, when only the
3D annotation exists, rendered from the labelled mesh into every camera.

    SRC/color/N.jpg                      colour (1296 x 968)
    SRC/depth/N.png                      uint16 depth in millimetres (640 x 480)
    SRC/pose/N.txt                       camera-to-world 4x4 (OpenCV axes); some frames are all -inf
    SRC/intrinsic/intrinsic_color.txt    4x4 (the 3x3 block is K of the colour images)
    SRC/intrinsic/intrinsic_depth.txt
    2D annotation:  SRC/instance-filt/N.png, SRC/label-filt/N.png, and a label map TSV
                    (scannetv2-labels.combined.tsv in SRC, or --labels) naming the label ids
    3D annotation:  SRC/<scene>_vh_clean_2.ply, SRC/<scene>.aggregation.json,
                    SRC/<scene>_vh_clean_2.0.010000.segs.json

Colour is resized to the depth resolution (the intrinsics scaled with it) unless ``resolution='color'``,
which resizes depth and masks to the colour size (nearest neighbour). Frames whose pose is not finite
(ScanNet marks lost tracking with -inf) are dropped and counted in the report.
"""

from __future__ import annotations

import csv
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image

from rescene_core.capture.format import FRAME_SLAB
from rescene_core.capture.importers.common import (
    ImportInputError,
    ImportOptions,
    SourceFrames,
    intrinsics,
    is_structural,
    list_images,
    load_frames,
    match_stems,
    read_matrix,
    read_parallel,
    read_png_int,
    require_dir,
    require_file,
    resize,
    select_frames,
)
from rescene_core.capture.importers.writer import finish_import
from rescene_core.render.raycast import RayCaster
from rescene_core.segment.project import labelled_meshes, render_masks

LABEL_MAP_NAME = "scannetv2-labels.combined.tsv"


def read_label_map(path: Path) -> dict[int, str]:
    """ScanNet's label map TSV: the ``id`` column -> ``category`` (or ``raw_category``)."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f, delimiter="\t"))
    except OSError as err:
        raise ImportInputError(f"{path}: unreadable label map ({err})") from err
    if not rows or "id" not in rows[0]:
        raise ImportInputError(f"{path}: not a ScanNet label map (needs an 'id' column and 'category')")
    out = {}
    for r in rows:
        try:
            out[int(r["id"])] = (r.get("category") or r.get("raw_category") or "").strip() or f"class {r['id']}"
        except ValueError:
            continue
    return out


def _find(src: Path, pattern: str) -> Path | None:
    hits = sorted(src.glob(pattern))
    return hits[0] if hits else None


def read_scannet(src: str | Path, opts: ImportOptions, mask_dir: Path | None = None) -> SourceFrames:
    """Read a ScanNet export; masks from ``mask_dir`` (panoptic), the 2D annotation, or the 3D one."""
    src = Path(src)
    require_dir(src, "source", "pass the exported scene folder (color/, depth/, pose/, intrinsic/)")
    color = require_dir(src / "color", "colour", "export colour images with ScanNet's reader")
    depth_dir = require_dir(src / "depth", "depth", "export depth images with ScanNet's reader")
    pose_dir = require_dir(src / "pose", "pose", "export poses with ScanNet's reader")
    intr = require_dir(src / "intrinsic", "intrinsics", "export intrinsics with ScanNet's reader")
    k_color = intrinsics(
        read_matrix(require_file(intr / "intrinsic_color.txt", "colour intrinsics", "export intrinsics"), (3, 3)),
        str(intr / "intrinsic_color.txt"),
    )
    rgb_files = list_images(color, (".jpg", ".jpeg", ".png"))
    if not rgb_files:
        raise ImportInputError(f"{color}: no colour images")
    depth_files = list_images(depth_dir, (".png",))
    pose_files = sorted(pose_dir.glob("*.txt"))
    match_stems(rgb_files, depth_files, color, depth_dir)
    match_stems(rgb_files, pose_files, color, pose_dir)
    by_depth = {p.stem: p for p in depth_files}
    by_pose = {p.stem: p for p in pose_files}
    keep = select_frames(len(rgb_files), opts)
    poses = []
    for k in keep:
        try:
            pose = np.loadtxt(by_pose[rgb_files[k].stem], dtype=np.float64)
        except Exception as err:
            raise ImportInputError(f"{by_pose[rgb_files[k].stem]}: not a 4x4 matrix ({err})") from err
        if pose.shape != (4, 4):
            raise ImportInputError(f"{by_pose[rgb_files[k].stem]}: shape {pose.shape}, expected a 4x4 matrix")
        poses.append(pose)

    notes: list[str] = []
    labels: dict[int, tuple[str, bool]] = {}
    mask_files = None
    render = None
    label_files = None
    if opts.segment == "geometric" and mask_dir is None:
        notes.append("the scene's annotation is not read (--segment geometric)")
    elif mask_dir is not None:
        masks = list_images(mask_dir, (".png",))
        match_stems(rgb_files, masks, color, mask_dir)
        by = {p.stem: p for p in masks}
        mask_files = [by[rgb_files[k].stem] for k in keep]
    elif (src / "instance-filt").is_dir():
        inst_dir, lab_dir = src / "instance-filt", require_dir(src / "label-filt", "label-filt", "export the 2D labels")
        inst = list_images(inst_dir, (".png",))
        labs = list_images(lab_dir, (".png",))
        match_stems(rgb_files, inst, color, inst_dir)
        match_stems(rgb_files, labs, color, lab_dir)
        by_i, by_l = {p.stem: p for p in inst}, {p.stem: p for p in labs}
        mask_files = [by_i[rgb_files[k].stem] for k in keep]
        label_files = [by_l[rgb_files[k].stem] for k in keep]
        notes.append("instance masks from the 2D annotation export (instance-filt, label-filt)")
    else:
        ply = _find(src, "*_vh_clean_2.ply")
        agg = _find(src, "*.aggregation.json")
        segs = _find(src, "*_vh_clean_2.0.010000.segs.json")
        if ply is None or agg is None or segs is None:
            missing = [n for n, p in (("*_vh_clean_2.ply", ply), ("*.aggregation.json", agg),
                                      ("*_vh_clean_2.0.010000.segs.json", segs)) if p is None]  # fmt: skip
            raise ImportInputError(
                f"{src}: no instance masks: neither instance-filt/ + label-filt/ (2D annotation) nor the 3D "
                f"annotation ({', '.join(missing)} missing); export the annotation or pass --segment geometric"
            )
        verts, faces, vlabel, labels = read_mesh_annotation(ply, agg, segs)
        notes.append(f"instance masks rendered from the 3D annotation ({ply.name}) with a depth test")

        def render(frames: SourceFrames) -> None:

            fl = vlabel[faces]
            face_label = np.where((fl[:, 0] == fl[:, 1]) | (fl[:, 0] == fl[:, 2]), fl[:, 0], fl[:, 1])
            caster = RayCaster(labelled_meshes(verts, faces, face_label))
            h, w = frames.rgb.shape[1:3]
            if frames.store is None:
                frames.masks, stats = render_masks(caster, frames.K, frames.world_from_cam, w, h, frames.depth)
            else:  # rendered a slab of frames at a time into the frame store
                masks = frames.store.new_masks()
                stats = Counter()
                for a in range(0, len(frames.names), FRAME_SLAB):
                    b = min(a + FRAME_SLAB, len(frames.names))
                    depth = None if frames.depth is None else np.asarray(frames.depth[a:b])
                    slab, st = render_masks(caster, frames.K[a:b], frames.world_from_cam[a:b], w, h, depth)
                    masks.array[a:b] = slab
                    stats.update(st)
                frames.masks = masks
            frames.notes.append(f"3D annotation render: {stats['rejected_by_depth']} pixels rejected by the depth test")

    probe = by_depth[rgb_files[keep[0]].stem] if opts.resolution == "depth" else rgb_files[keep[0]]
    try:
        with Image.open(probe) as im:
            size = im.size
    except Exception as err:
        raise ImportInputError(f"{probe}: unreadable image ({err})") from err
    if opts.resolution == "depth":
        notes.append(f"colour resized to the depth resolution {size[0]}x{size[1]} (intrinsics scaled)")
    else:
        notes.append(f"depth and masks resized to the colour resolution {size[0]}x{size[1]} (nearest neighbour)")
    frames = load_frames(
        "scannet",
        src,
        [rgb_files[k].stem for k in keep],
        keep,
        [rgb_files[k] for k in keep],
        [by_depth[rgb_files[k].stem] for k in keep],
        poses,
        [k_color] * len(keep),
        opts,
        opts.depth_scale,
        mask_files=mask_files,
        size=size,
        frames_in_source=len(rgb_files),
    )
    frames.notes = notes + frames.notes
    frames.render_masks = render
    if label_files is not None:
        names = frames.names
        kept_files = {p.stem: p for p in label_files}
        labels = _labels_2d(frames, [kept_files[n] for n in names], src, opts)
    frames.labels = labels
    return frames


def _labels_2d(
    frames: SourceFrames, label_files: list[Path], src: Path, opts: ImportOptions
) -> dict[int, tuple[str, bool]]:
    """Each instance's label: the most frequent label-filt id under its pixels, named by the label map."""

    tsv = src / LABEL_MAP_NAME
    names = read_label_map(tsv) if tsv.is_file() else {}
    votes: dict[int, Counter] = {}
    masks = frames.masks
    if masks is None:
        raise ImportInputError(f"{src}: ScanNet 2D labels need the instance masks (instance-filt) to vote on")
    h, w = masks.shape[1:]

    def frame_votes(t: int) -> tuple[np.ndarray, np.ndarray]:
        # one int64 key per (instance, label) pair: a 1-D unique is a plain sort, where np.unique(axis=0)
        # sorts row views (0.2 s a 640x480 frame)
        lab = read_png_int(label_files[t]).astype(np.int64)
        if lab.shape != (h, w):
            lab = resize(lab, w, h, nearest=True)
        m = masks[t]
        sel = m > 0
        return np.unique((m[sel].astype(np.int64) << 32) | (lab[sel] & 0xFFFFFFFF), return_counts=True)

    for keys, counts in read_parallel(frame_votes, len(label_files), opts.threads):
        for key, c in zip(keys.tolist(), counts.tolist()):
            votes.setdefault(key >> 32, Counter())[key & 0xFFFFFFFF] += c
    if not names:
        frames.notes.append(f"no {LABEL_MAP_NAME} in {src}: labels are 'class <id>'")
    out = {}
    for i, v in votes.items():
        lid = v.most_common(1)[0][0]
        name = names.get(lid, f"class {lid}") if lid > 0 else "object"
        out[i] = (name, is_structural(name))
    return out


def read_mesh_annotation(
    ply: Path, agg: Path, segs: Path
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, tuple[str, bool]]]:
    """Vertices [v, 3], faces [f, 3], instance id per vertex (objectId + 1, 0 = none) and labels."""

    try:
        mesh = trimesh.load(ply, process=False, force="mesh")
    except Exception as err:
        raise ImportInputError(f"{ply}: unreadable mesh ({err})") from err
    if not isinstance(mesh, trimesh.Trimesh):
        raise ImportInputError(f"{ply}: not a triangle mesh ({type(mesh).__name__})")
    try:
        seg_idx = np.asarray(json.loads(segs.read_text())["segIndices"], np.int64)
        groups = json.loads(agg.read_text())["segGroups"]
    except (json.JSONDecodeError, KeyError) as err:
        raise ImportInputError(f"{segs.name} / {agg.name}: not ScanNet annotation files ({err})") from err
    verts = np.asarray(mesh.vertices, np.float64)
    if len(seg_idx) != len(verts):
        raise ImportInputError(f"{segs}: {len(seg_idx)} segment indices for {len(verts)} vertices of {ply.name}")
    seg_to_inst = {}
    labels = {}
    for g in groups:
        iid = int(g["objectId"]) + 1
        labels[iid] = (str(g["label"]), is_structural(str(g["label"])))
        for s in g["segments"]:
            seg_to_inst[int(s)] = iid
    vlabel = np.array([seg_to_inst.get(int(s), 0) for s in seg_idx], np.int64)
    return verts, np.asarray(mesh.faces, np.int64), vlabel, labels


def import_scannet(
    src: str | Path, out: str | Path, opts: ImportOptions | None = None, **configs: Any
) -> dict[str, Any]:
    """Import a ScanNet export into a capture at ``out``; returns the import report."""

    opts = opts or ImportOptions()
    started = time.perf_counter()
    frames = read_scannet(src, opts)
    return finish_import(frames, out, opts, started, **configs)
