"""RGB-D folders (the DeepVideoMVS layout of phone and headset recordings):

    SRC/images/NNNNN.{jpg,png}   colour
    SRC/depth/NNNNN.png          uint16 depth (millimetres by default; --depth-scale)
    SRC/poses.txt                one 4x4 pose a line (16 numbers, row-major), in the order of the names
    SRC/K.txt                    3x3 pinhole intrinsics for every frame

Poses are camera-to-world with OpenCV camera axes unless ``pose_convention`` / ``camera_axes`` say
otherwise. ``SRC/instances/`` (per-frame instance PNGs) is read by the panoptic importer, not here.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture.importers.common import (
    ImportInputError,
    ImportOptions,
    SourceFrames,
    convert_pose,
    intrinsics,
    list_images,
    load_frames,
    match_stems,
    read_matrix,
    require_dir,
    require_file,
    select_frames,
)
from rescene_core.capture.importers.writer import finish_import


def read_rgbd(src: str | Path, opts: ImportOptions, mask_dir: Path | None = None) -> SourceFrames:
    """Read an RGB-D folder (and optionally per-frame instance PNGs of the same names)."""
    src = Path(src)
    require_dir(src, "source", "pass the folder that holds images/, depth/, poses.txt and K.txt")
    images = require_dir(src / "images", "colour", "put the colour frames in SRC/images/")
    depth_dir = require_dir(src / "depth", "depth", "put uint16 depth PNGs named like the images in SRC/depth/")
    poses_file = require_file(src / "poses.txt", "the pose file", "write one 4x4 camera pose a line")
    k_file = require_file(src / "K.txt", "the intrinsics file", "write the 3x3 pinhole matrix")
    rgb_files = list_images(images)
    if not rgb_files:
        raise ImportInputError(f"{images}: no .jpg or .png images")
    depth_files = list_images(depth_dir, (".png",))
    match_stems(rgb_files, depth_files, images, depth_dir)
    by_stem = {p.stem: p for p in depth_files}
    depth_files = [by_stem[p.stem] for p in rgb_files]
    if not poses_file.read_text().strip():
        raise ImportInputError(f"{poses_file}: no poses (the file is empty); write one 4x4 camera pose a line")
    try:
        raw = np.loadtxt(poses_file, dtype=np.float64, ndmin=2)
    except Exception as err:
        raise ImportInputError(f"{poses_file}: not a table of numbers ({err})") from err
    if raw.shape[1] == 12:  # 3x4 rows: add the homogeneous row
        raw = np.concatenate([raw, np.tile([0.0, 0.0, 0.0, 1.0], (len(raw), 1))], axis=1)
    if raw.shape[1] != 16:
        raise ImportInputError(f"{poses_file}: lines have {raw.shape[1]} numbers; write 16 (a row-major 4x4) per line")
    if len(raw) != len(rgb_files):
        raise ImportInputError(
            f"{poses_file}: has {len(raw)} poses for {len(rgb_files)} images in {images} "
            "(write one pose per image, in the order of the file names)"
        )
    K = intrinsics(read_matrix(k_file, (3, 3)), str(k_file))
    mask_files = None
    if mask_dir is not None:
        mask_list = list_images(mask_dir, (".png",))
        match_stems(rgb_files, mask_list, images, mask_dir)
        by_mask = {p.stem: p for p in mask_list}
        mask_files = [by_mask[p.stem] for p in rgb_files]
    keep = select_frames(len(rgb_files), opts)
    poses = [convert_pose(raw[k].reshape(4, 4), opts) for k in keep]
    return load_frames(
        "rgbd",
        src,
        [rgb_files[k].stem for k in keep],
        keep,
        [rgb_files[k] for k in keep],
        [depth_files[k] for k in keep],
        poses,
        [K] * len(keep),
        opts,
        opts.depth_scale,
        mask_files=None if mask_files is None else [mask_files[k] for k in keep],
        frames_in_source=len(rgb_files),
    )


def import_rgbd(src: str | Path, out: str | Path, opts: ImportOptions | None = None, **configs: Any) -> dict[str, Any]:
    """Import an RGB-D folder into a capture at ``out``; returns the import report."""

    opts = opts or ImportOptions()
    started = time.perf_counter()
    frames = read_rgbd(src, opts)
    return finish_import(frames, out, opts, started, **configs)
