"""nerfstudio folders: ``transforms.json`` with camera-to-world ``transform_matrix`` per frame in OpenGL camera
axes (x right, y up, z back), converted here to the capture's OpenCV axes.

    SRC/transforms.json   fl_x, fl_y, cx, cy, w, h (shared, or per frame), frames: [{file_path,
                          transform_matrix, depth_file_path?}], optional depth_unit_scale_factor
    SRC/<file_path>       colour; SRC/<depth_file_path>: uint16 depth PNG (depth_unit_scale_factor, default
                          --depth-scale, metres per unit)

Images must be undistorted (camera_model PINHOLE, or OPENCV with zero distortion coefficients).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from rescene_core.capture.importers.common import (
    ImportInputError,
    ImportOptions,
    SourceFrames,
    convert_pose,
    intrinsics,
    list_images,
    load_frames,
    match_stems,
    require_dir,
    require_file,
    scale_intrinsics,
    select_frames,
)
from rescene_core.capture.importers.writer import finish_import

DISTORTION_KEYS = ("k1", "k2", "k3", "k4", "p1", "p2")


def _intrinsics(meta: dict[str, Any], frame: dict[str, Any], where: str) -> tuple[np.ndarray, tuple[int, int] | None]:
    get = {k: frame.get(k, meta.get(k)) for k in ("fl_x", "fl_y", "cx", "cy", "w", "h")}
    missing = [k for k in ("fl_x", "cx", "cy") if get[k] is None]
    if missing:
        raise ImportInputError(f"{where}: intrinsics {missing} are missing (give them at the top or per frame)")
    fy = get["fl_y"] if get["fl_y"] is not None else get["fl_x"]
    K = intrinsics(np.array([[get["fl_x"], 0, get["cx"]], [0, fy, get["cy"]], [0, 0, 1]], float), where)
    dist = {k: frame.get(k, meta.get(k, 0.0)) or 0.0 for k in DISTORTION_KEYS}
    if any(abs(float(v)) > 1e-9 for v in dist.values()):
        raise ImportInputError(
            f"{where}: the images are distorted ({', '.join(k for k, v in dist.items() if v)}); "
            "undistort them first (e.g. ns-process-data) and write zero coefficients"
        )
    size = (int(get["w"]), int(get["h"])) if get["w"] and get["h"] else None
    return K, size


def read_nerfstudio(src: str | Path, opts: ImportOptions, mask_dir: Path | None = None) -> SourceFrames:
    """Read a nerfstudio folder (and optionally per-frame instance PNGs named like the images)."""
    src = Path(src)
    require_dir(src, "source", "pass the folder that holds transforms.json")
    tf = require_file(src / "transforms.json", "transforms.json", "write a nerfstudio transforms.json")
    try:
        meta = json.loads(tf.read_text())
    except json.JSONDecodeError as err:
        raise ImportInputError(f"{tf}: not valid JSON ({err})") from err
    frames = meta.get("frames")
    if not isinstance(frames, list) or not frames:
        raise ImportInputError(f"{tf}: 'frames' is missing or empty")
    opts_gl = opts.model_copy(update={"camera_axes": "opengl", "pose_convention": "cam_to_world"})
    scale = float(meta.get("depth_unit_scale_factor", opts.depth_scale))
    has_depth = ["depth_file_path" in f for f in frames]
    if any(has_depth) and not all(has_depth):
        first = has_depth.index(False)
        raise ImportInputError(f"{tf}: frame {first} has no depth_file_path while others do; give every frame one")
    rgb_files, depth_files, poses, Ks, names = [], [], [], [], []
    for k, f in enumerate(frames):
        where = f"{tf} frames[{k}]"
        if "file_path" not in f or "transform_matrix" not in f:
            raise ImportInputError(f"{where}: needs file_path and transform_matrix")
        rgb_files.append(require_file(src / f["file_path"], "image", f"fix file_path in {tf.name}"))
        if has_depth[k]:
            depth_files.append(
                require_file(src / f["depth_file_path"], "depth image", f"fix depth_file_path in {tf.name}")
            )
        pose = np.asarray(f["transform_matrix"], float)
        if pose.shape == (3, 4):
            pose = np.vstack([pose, [0, 0, 0, 1]])
        if pose.shape != (4, 4):
            raise ImportInputError(f"{where}: transform_matrix is {pose.shape}, expected 4x4")
        poses.append(pose)
        Ks.append(_intrinsics(meta, f, where))
        names.append(Path(f["file_path"]).stem)
    order = sorted(range(len(frames)), key=lambda k: (len(names[k]), names[k]))
    keep = [order[k] for k in select_frames(len(order), opts)]
    mask_files = None
    if mask_dir is not None:
        masks = list_images(mask_dir, (".png",))
        match_stems(rgb_files, masks, src / "images", mask_dir)
        by = {p.stem: p for p in masks}
        mask_files = [by[rgb_files[k].stem] for k in keep]
    # intrinsics are for the image size (w, h) of transforms.json; images stored at another size scale them

    K_list = []
    for k in keep:
        K, size = Ks[k]
        if size is not None:
            try:
                with Image.open(rgb_files[k]) as im:
                    actual = im.size
            except Exception as err:
                raise ImportInputError(f"{rgb_files[k]}: unreadable image ({err})") from err
            if actual != size:
                K = scale_intrinsics(K, size[0], size[1], actual[0], actual[1])
        K_list.append(K)
    return load_frames(
        "nerfstudio",
        src,
        [names[k] for k in keep],
        keep,
        [rgb_files[k] for k in keep],
        [depth_files[k] for k in keep] if depth_files else None,
        [convert_pose(poses[k], opts_gl) for k in keep],
        K_list,
        opts,
        scale,
        mask_files=mask_files,
        frames_in_source=len(frames),
    )


def import_nerfstudio(
    src: str | Path, out: str | Path, opts: ImportOptions | None = None, **configs: Any
) -> dict[str, Any]:
    """Import a nerfstudio folder into a capture at ``out``; returns the import report."""

    opts = opts or ImportOptions()
    started = time.perf_counter()
    frames = read_nerfstudio(src, opts)
    frames.notes.append("OpenGL camera axes of transforms.json converted to OpenCV")
    return finish_import(frames, out, opts, started, **configs)
