"""What every importer shares: the options, the frames read from a source, per-file readers that name the
file in their errors, pose and depth sanity checks, and the report.

An importer reads its layout into ``SourceFrames`` (poses in the capture's OpenCV camera convention, the
source's own world frame) and hands it to ``rescene_core.capture.importers.writer.finish_import``, which
aligns, segments, fuses and writes the capture.
"""

from __future__ import annotations

import csv
import functools
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from PIL import Image
from pydantic import BaseModel, ConfigDict

from rescene_core.capture.format import FrameData, FrameStore, iter_slabs

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png")
"""Image files an importer reads (lower-case suffixes)."""


class ImportInputError(ValueError):
    """The source cannot be imported; the message names the file, what is wrong and the fix."""


class ImportOptions(BaseModel):
    """Options of ``rescene import``. Lengths in metres."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    scene_id: str | None = None
    """Name of the scene (default: the source folder's name)."""
    stride: int = 1
    """Keep every n-th frame of the source."""
    max_frames: int | None = None
    """Keep at most this many frames (after the stride)."""
    depth_scale: float = 0.001
    """Metres per unit of the depth PNGs (0.001: millimetres, the usual uint16 encoding)."""
    pose_convention: Literal["cam_to_world", "world_to_cam"] = "cam_to_world"
    """Whether the source's poses map camera to world (ScanNet, DeepVideoMVS) or world to camera."""
    camera_axes: Literal["opencv", "opengl"] = "opencv"
    """Camera axes of the source's poses: OpenCV (x right, y down, z forward) or OpenGL (y up, z back)."""
    align: Literal["floor", "none"] = "floor"
    """'floor': rotate the world to z up with the floor at z = 0; 'none': keep the source frame (it must
    already be z up)."""
    up: tuple[float, float, float] | None = None
    """The recorder's up direction (minus its gravity) in the source's world frame, e.g. (0, 1, 0) for a
    y-up headset; None: SRC/gravity.txt or an Aria MPS closed_loop_trajectory.csv when the source has one,
    else the floor search from the cameras alone."""
    max_tilt: float | None = None
    """Largest angle between the floor normal and the prior up (deg): the given gravity's (default 10) or
    the cameras' mean up (default 80); None: the alignment's defaults."""
    segment: Literal["none", "geometric", "masks"] = "none"
    """Instance masks: 'none' takes them from the source; 'geometric' makes them without labels (TSDF,
    planes removed, superpoints merged by geometry and colour, rendered back into every frame); 'masks'
    merges the superpoints by the view consensus of a 2D segmenter's per-frame masks (``--masks DIR``)."""
    clip_model: str | None = None
    """Local open_clip checkpoint: label the segments of --segment geometric or masks zero-shot over ``vocabulary``."""
    clip_model_name: str = "ViT-B-32"
    """open_clip architecture of ``clip_model``."""
    vocabulary: tuple[str, ...] = (
        "chair", "table", "sofa", "bed", "cabinet", "shelf", "desk", "lamp", "plant", "box", "monitor",
        "bag", "trash can", "pillow", "stool", "bench", "door", "picture", "window", "person",
    )  # fmt: skip
    """Labels the zero-shot classifier chooses from."""
    resolution: Literal["depth", "color"] = "depth"
    """ScanNet: resize colour to the depth resolution ('depth') or depth and masks to colour ('color')."""
    max_depth: float = 8.0
    """Depth beyond this is treated as invalid (m)."""
    min_depth: float = 0.1
    """Depth nearer than this is treated as invalid (m)."""
    depth_unit_max_median: float = 20.0
    """A median valid depth above this is a unit mistake (m): the import stops and names the fix."""
    depth_unit_min_median: float = 0.05
    """A median valid depth below this is a unit mistake (m)."""
    rotation_tolerance: float = 1e-3
    """Poses whose 3x3 block is further than this from a rotation are dropped (smaller errors are
    re-orthonormalised)."""
    max_unreadable_fraction: float = 0.5
    """More unreadable frames than this fraction stops the import instead of dropping them."""
    threads: int = 2
    """Image reading threads."""
    overwrite: bool = False
    """Replace an existing capture at the output path."""


@dataclass
class Dropped:
    """A source frame that was not imported: its index in the source, the file and why."""

    frame: int
    file: str
    reason: str

    def to_json(self) -> dict[str, Any]:
        return {"frame": self.frame, "file": self.file, "reason": self.reason}


@dataclass
class SourceFrames:
    """Frames read from a source, before alignment and segmentation.

    names: [T] frame names (file stems). rgb: uint8 [T, H, W, 3]. depth: float32 [T, H, W] metres along
    camera z (0 = invalid) or None. K: float64 [T, 3, 3]. world_from_cam: float64 [T, 4, 4], OpenCV axes,
    the source's world frame. masks: int32 [T, H, W] instance ids (0 = none) or None. labels: id ->
    (label, structural) for the ids in ``masks``. dropped: frames left out and why. notes: what the
    importer decided (resizing, conventions) in words.

    The per-pixel arrays are numpy arrays or frames on disk (``load_frames`` writes them into a
    ``FrameStore``, kept in ``store``): index them per frame or by a slice of frames.
    """

    source: str
    src: Path
    names: list[str]
    rgb: NDArray[np.uint8] | FrameData
    depth: NDArray[np.float32] | FrameData | None
    K: NDArray[np.float64]
    world_from_cam: NDArray[np.float64]
    masks: NDArray[np.int32] | FrameData | None = None
    labels: dict[int, tuple[str, bool]] = field(default_factory=dict)
    dropped: list[Dropped] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    frames_in_source: int = 0
    render_masks: Callable[[SourceFrames], None] | None = None
    """Set by importers whose masks come from a labelled mesh: fills ``masks`` after alignment checks."""
    store: FrameStore | None = None
    """The temporary store holding the frames (removed with it), when they are on disk."""


STRUCTURAL_LABELS = frozenset({"floor", "wall", "ceiling"})
"""Labels that mark room structure (no asset; they shape the room shell)."""


def is_structural(label: str) -> bool:
    return label.strip().lower() in STRUCTURAL_LABELS


def require_dir(path: Path, what: str, fix: str) -> Path:
    if not path.is_dir():
        raise ImportInputError(f"{path}: {what} folder is missing ({fix})")
    return path


def require_file(path: Path, what: str, fix: str) -> Path:
    if not path.is_file():
        raise ImportInputError(f"{path}: {what} is missing ({fix})")
    return path


def list_images(folder: Path, suffixes: Sequence[str] = IMAGE_SUFFIXES) -> list[Path]:
    """Image files of ``folder`` in natural order (numeric stems sort as numbers)."""
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in suffixes]
    return sorted(files, key=natural_key)


def natural_key(path: Path) -> tuple:
    stem = path.stem
    digits = "".join(ch for ch in stem if ch.isdigit())
    return (0, int(digits), stem) if digits else (1, 0, stem)


def match_stems(primary: list[Path], other: list[Path], primary_dir: Path, other_dir: Path) -> None:
    """Both folders hold the same frame names; otherwise name the missing and the extra files."""
    a = {p.stem: p for p in primary}
    b = {p.stem: p for p in other}
    missing = [a[s].name for s in a if s not in b]
    extra = [b[s].name for s in b if s not in a]
    if missing or extra:
        parts = []
        if missing:
            parts.append(f"{len(missing)} frame(s) of {primary_dir} have no file in {other_dir} (first: {missing[0]})")
        if extra:
            parts.append(f"{len(extra)} file(s) of {other_dir} have no frame in {primary_dir} (first: {extra[0]})")
        raise ImportInputError(
            f"{other_dir}: " + "; ".join(parts) + " (give every frame one file of the same name in each folder)"
        )


def read_rgb(path: Path) -> NDArray[np.uint8]:
    """An RGB image [H, W, 3] uint8; raises ImportInputError naming the file when unreadable."""

    try:
        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"), dtype=np.uint8)
    except Exception as err:
        raise ImportInputError(f"{path}: unreadable image ({type(err).__name__}: {err})") from err


def read_png_int(path: Path) -> NDArray:
    """A single-channel integer PNG (depth in units, instance or label ids) as an integer array [H, W]."""

    try:
        with Image.open(path) as im:
            arr = np.asarray(im)
    except Exception as err:
        raise ImportInputError(f"{path}: unreadable image ({type(err).__name__}: {err})") from err
    if arr.ndim == 3:
        if arr.shape[2] >= 3 and np.array_equal(arr[..., 0], arr[..., 1]) and np.array_equal(arr[..., 0], arr[..., 2]):
            arr = arr[..., 0]
        elif arr.shape[2] >= 3:  # an RGB-encoded id image: id = R + 256 G + 65536 B
            arr = (
                arr[..., 0].astype(np.int64) + 256 * arr[..., 1].astype(np.int64) + 65536 * arr[..., 2].astype(np.int64)
            )
        else:
            arr = arr[..., 0]
    if not np.issubdtype(arr.dtype, np.integer):
        raise ImportInputError(f"{path}: is {arr.dtype}, expected an integer PNG (uint8 or uint16)")
    return arr


def read_mask(path: Path) -> NDArray[np.int32]:
    """Instance ids [H, W] int32 (0 = none) from an integer PNG; ids beyond int32 are refused by name."""
    ids = read_png_int(path)
    if ids.size and (int(ids.min()) < 0 or int(ids.max()) > np.iinfo(np.int32).max):
        raise ImportInputError(
            f"{path}: instance ids outside 0..2^31-1 (max {int(ids.max())}); renumber the instance PNGs"
        )
    return ids.astype(np.int32, copy=False)


def read_depth(path: Path, scale: float, opts: ImportOptions) -> NDArray[np.float32]:
    """Metric depth [H, W] float32 from an integer PNG (units * scale); out-of-range values become 0."""
    raw = read_png_int(path)
    depth = raw.astype(np.float32) * np.float32(scale)
    depth[(depth < opts.min_depth) | (depth > opts.max_depth) | ~np.isfinite(depth)] = 0.0
    return depth


def check_depth_units(raw_medians: list[float], scale: float, where: Path, opts: ImportOptions) -> float:
    """The median valid depth in metres over the frames; a clear error when it says the unit is wrong."""
    med = float(np.median(raw_medians)) * scale if raw_medians else 0.0
    if not raw_medians:
        raise ImportInputError(f"{where}: no valid depth in any frame (check the depth files and --depth-scale)")
    if med > opts.depth_unit_max_median or med < opts.depth_unit_min_median:
        good = scale * 10.0 ** np.round(np.log10(1.5 / med)) if med > 0 else scale
        raise ImportInputError(
            f"{where}: median depth is {med:.4g} m with --depth-scale {scale:g}, not a room's depth "
            f"(fix: pass the metres per depth unit, e.g. --depth-scale {good:.3g})"
        )
    return med


def raw_depth_median(path: Path) -> float | None:
    raw = read_png_int(path)
    valid = raw[raw > 0]
    return float(np.median(valid)) if valid.size else None


def read_matrix(path: Path, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """A whitespace-separated matrix file, reshaped; errors name the file and the expected shape."""
    try:
        vals = np.loadtxt(path, dtype=np.float64, ndmin=1).ravel()
    except Exception as err:
        raise ImportInputError(f"{path}: not a whitespace-separated number matrix ({err})") from err
    n = int(np.prod(shape))
    if vals.size < n or (vals.size != n and shape != (3, 3)):
        raise ImportInputError(f"{path}: has {vals.size} numbers, expected {n} (a {'x'.join(map(str, shape))} matrix)")
    if vals.size != n:  # a 4x4 intrinsic file (ScanNet) read as 3x3
        if vals.size == 16:
            return vals.reshape(4, 4)[:3, :3].copy()
        raise ImportInputError(f"{path}: has {vals.size} numbers, expected 9 (3x3) or 16 (4x4)")
    return vals.reshape(shape)


def intrinsics(K: NDArray, where: str) -> NDArray[np.float64]:
    """A pinhole K [3, 3], checked: finite, fx, fy > 0, zero skew."""
    K = np.asarray(K, np.float64)
    if K.shape != (3, 3) or not np.isfinite(K).all() or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ImportInputError(
            f"{where}: not a pinhole matrix [[fx,0,cx],[0,fy,cy],[0,0,1]] with fx, fy > 0: {K.tolist()}"
        )
    out = np.array([[K[0, 0], 0.0, K[0, 2]], [0.0, K[1, 1], K[1, 2]], [0.0, 0.0, 1.0]])
    return out


OPENGL_FROM_OPENCV = np.diag([1.0, -1.0, -1.0, 1.0])
"""Flips camera y and z: an OpenGL camera pose times this is the OpenCV pose of the same camera."""


def convert_pose(pose: NDArray, opts: ImportOptions) -> NDArray[np.float64]:
    """A source pose [4, 4] -> world_from_cam with OpenCV axes (may be non-finite; checked later)."""
    pose = np.asarray(pose, np.float64)
    if opts.pose_convention == "world_to_cam" and np.isfinite(pose).all():
        try:
            pose = np.linalg.inv(pose)
        except np.linalg.LinAlgError:
            pose = np.full((4, 4), np.nan)
    if opts.camera_axes == "opengl":
        pose = pose @ OPENGL_FROM_OPENCV
    return pose


def check_pose(pose: NDArray, tolerance: float) -> tuple[NDArray[np.float64] | None, str]:
    """(rigid pose, '') or (None, why it is dropped). Small rotation errors are re-orthonormalised (SVD)."""
    if not np.isfinite(pose).all():
        return None, "pose has NaN or infinite values"
    if np.abs(pose[3] - [0, 0, 0, 1]).max() > 1e-6:
        return None, "pose's last row is not [0, 0, 0, 1]"
    rot = pose[:3, :3]
    err = max(float(np.abs(rot.T @ rot - np.eye(3)).max()), abs(float(np.linalg.det(rot)) - 1.0))
    if err > tolerance:
        return None, f"pose is not rigid (rotation error {err:.3g}: scaled, sheared or reflected)"
    u, _, vt = np.linalg.svd(rot)
    out = pose.copy()
    out[:3, :3] = u @ vt
    return out, ""


READ_CHUNK = 32
"""Frames decoded per batch of the reading threads (each batch is written into the frame store at once:
32 640x480 frames hold 110 MB)."""


def read_parallel(fn: Callable[[int], Any], n: int, threads: int) -> list[Any]:
    """``[fn(0), ..., fn(n - 1)]`` with a thread pool (image decoding releases the GIL)."""
    if threads <= 1 or n <= 1:
        return [fn(k) for k in range(n)]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        return list(pool.map(fn, range(n)))


def _offset_call(fn: Callable[[int], Any], offset: int, k: int) -> Any:
    return fn(offset + k)


def select_frames(n: int, opts: ImportOptions) -> list[int]:
    """Indices of the source frames kept by the stride and the frame cap."""
    if opts.stride < 1:
        raise ImportInputError(f"--stride is {opts.stride}; use a positive integer")
    keep = list(range(0, n, opts.stride))
    if opts.max_frames is not None:
        if opts.max_frames < 1:
            raise ImportInputError(f"--max-frames is {opts.max_frames}; keep at least one frame")
        keep = keep[: opts.max_frames]
    return keep


GRAVITY_FILE = "gravity.txt"
"""A source's own gravity: three numbers, the gravity vector (pointing down, any length) in its world frame."""
ARIA_TRAJECTORY = "closed_loop_trajectory.csv"
"""Aria MPS trajectory; its gravity_x_world, gravity_y_world, gravity_z_world columns are the gravity."""


def read_source_gravity(src: Path) -> tuple[NDArray[np.float64], str] | None:
    """The recorder's up (unit [3], minus its gravity) from the source folder, and the file it came from:
    ``SRC/gravity.txt`` or the median gravity of an Aria MPS ``SRC/closed_loop_trajectory.csv``; None when
    the source has neither. A file that is there but unreadable stops the import with its name."""
    path = src / GRAVITY_FILE
    if path.is_file():
        try:
            g = np.loadtxt(path, dtype=np.float64, ndmin=1).ravel()
        except Exception as err:
            raise ImportInputError(
                f"{path}: not three numbers ({err}); write the gravity vector, e.g. 0 -9.81 0"
            ) from err
        return _up_from_gravity(g, path), str(path)
    path = src / ARIA_TRAJECTORY
    if path.is_file():
        cols = ("gravity_x_world", "gravity_y_world", "gravity_z_world")
        try:
            with path.open(newline="") as f:
                rows = [[float(r[c]) for c in cols] for r in csv.DictReader(f) if all(r.get(c) for c in cols)]
        except (ValueError, KeyError, csv.Error) as err:
            raise ImportInputError(f"{path}: unreadable gravity columns {', '.join(cols)} ({err})") from err
        if not rows:
            return None  # a trajectory without gravity columns: the floor search decides
        return _up_from_gravity(np.median(np.asarray(rows), axis=0), path), str(path)
    return None


def _up_from_gravity(g: NDArray[np.float64], where: Path) -> NDArray[np.float64]:
    if g.shape != (3,) or not np.isfinite(g).all() or np.linalg.norm(g) < 1e-9:
        raise ImportInputError(
            f"{where}: gravity must be three finite numbers, not all zero (got {g.tolist()}); e.g. 0 -9.81 0"
        )
    return -g / np.linalg.norm(g)


def load_frames(
    source: str,
    src: Path,
    names: list[str],
    source_index: list[int],
    rgb_files: list[Path],
    depth_files: list[Path] | None,
    poses: list[NDArray],
    Ks: list[NDArray],
    opts: ImportOptions,
    depth_scale: float,
    mask_files: list[Path] | None = None,
    size: tuple[int, int] | None = None,
    frames_in_source: int = 0,
) -> SourceFrames:
    """Read the kept frames: poses checked (bad ones dropped and counted), images and depth decoded in
    parallel (unreadable frames dropped and counted), depth units checked, sizes made to agree.

    size: (width, height) every image is brought to; None: the first readable depth (or colour) frame's.
    Intrinsics follow a resize of the colour image (scaled by the size ratio).
    """
    dropped: list[Dropped] = []
    ok: list[int] = []
    good_poses: list[NDArray] = []
    for k, pose in enumerate(poses):
        fixed, why = check_pose(pose, opts.rotation_tolerance)
        if fixed is None:
            dropped.append(Dropped(source_index[k], rgb_files[k].name, why))
        else:
            ok.append(k)
            good_poses.append(fixed)
    if not poses:
        raise ImportInputError(f"{src}: no frames to import (an empty source); check the image and pose files")
    if not ok:
        reasons = sorted({d.reason for d in dropped})
        raise ImportInputError(f"{src}: every frame's pose is unusable ({'; '.join(reasons)}); check the pose files")
    if depth_files is not None:
        probe = [depth_files[k] for k in ok[:: max(1, len(ok) // 10)]]
        medians = [m for m in (_safe_median(p) for p in probe) if m is not None]
        check_depth_units(medians, depth_scale, depth_files[ok[0]].parent, opts)

    def read(j: int) -> tuple[NDArray, NDArray | None, NDArray | None, tuple[int, int]] | ImportInputError:
        """Frame j decoded: colour (brought to ``size`` here, in the reading thread, when it is known),
        depth, mask, and the colour's own (height, width)."""
        k = ok[j]
        try:
            rgb = read_rgb(rgb_files[k])
            depth = read_depth(depth_files[k], depth_scale, opts) if depth_files is not None else None
            mask = read_mask(mask_files[k]) if mask_files is not None else None
        except ImportInputError as err:
            return err
        shape = (int(rgb.shape[0]), int(rgb.shape[1]))
        if size is not None and shape != (size[1], size[0]):
            rgb = resize(rgb, size[0], size[1], nearest=False)
        return rgb, depth, mask, shape

    # Frames are decoded a chunk at a time and written into a temporary zarr store with the capture's own
    # chunks and codec (``FrameStore``); the capture writer takes those chunk files over, so reading holds
    # two chunks of frames (one being encoded in a writer thread while the next is decoded), whatever the
    # scan's length.
    n_ok = len(ok)
    writer = ThreadPoolExecutor(max_workers=1)
    pending: Future[None] | None = None
    store: FrameStore | None = None
    K_out = np.zeros((n_ok, 3, 3))
    kept: list[int] = []
    resized_rgb = resized_depth = False
    w = h = 0
    for lo in range(0, n_ok, READ_CHUNK):
        chunk = range(lo, min(lo + READ_CHUNK, n_ok))
        loaded = read_parallel(functools.partial(_offset_call, read, lo), len(chunk), opts.threads)
        first = len(kept)
        rgbs: list[NDArray] = []
        depths: list[NDArray] = []
        masks: list[NDArray] = []
        for j, item in zip(chunk, loaded, strict=True):
            k = ok[j]
            if isinstance(item, ImportInputError):
                dropped.append(Dropped(source_index[k], rgb_files[k].name, f"unreadable: {item}"))
                continue
            rgb, depth, mask, rgb_shape = item
            if store is None:
                if size is None:
                    ref = depth if depth is not None else rgb
                    size = (ref.shape[1], ref.shape[0])
                w, h = size
                store = FrameStore(n_ok, h, w, depth_files is not None, mask_files is not None)
            K = np.asarray(Ks[k], np.float64).copy()
            if rgb_shape != (h, w):
                K = scale_intrinsics(K, rgb_shape[1], rgb_shape[0], w, h)
                resized_rgb = True
            if rgb.shape[:2] != (h, w):  # the first frame, read before the size was known
                rgb = resize(rgb, w, h, nearest=False)
            rgbs.append(rgb)
            K_out[len(kept)] = K
            if depth is not None:
                if depth.shape != (h, w):
                    depth = resize(depth, w, h, nearest=True)
                    resized_depth = True
                depths.append(depth)
            if mask is not None:
                masks.append(mask if mask.shape == (h, w) else resize(mask, w, h, nearest=True))
            kept.append(j)
        del loaded
        if pending is not None:
            pending.result()  # one chunk in flight: memory stays at two chunks
            pending = None
        if store is not None and rgbs:
            pending = writer.submit(
                store.write,
                first,
                np.stack(rgbs),
                np.stack(depths) if depths else None,
                np.stack(masks).astype(np.int32, copy=False) if masks else None,
            )
        del rgbs, depths, masks
    if pending is not None:
        pending.result()
    writer.shutdown()
    unreadable = sum(1 for d in dropped if d.reason.startswith("unreadable"))
    if store is None or not kept or unreadable > opts.max_unreadable_fraction * n_ok:
        first_bad = next((d for d in dropped if d.reason.startswith("unreadable")), None)
        raise ImportInputError(
            f"{src}: {unreadable} of {n_ok} frames are unreadable"
            + (f" (first: {first_bad.reason})" if first_bad else "")
            + "; re-export the images"
        )
    n = len(kept)  # the store's unwritten tail (dropped frames) is cut off
    store.truncate(n)
    K_out = K_out[:n]
    notes: list[str] = []
    if resized_rgb:
        notes.append(f"colour resized to {w}x{h} (intrinsics scaled to match)")
    if resized_depth:
        notes.append(f"depth resized to {w}x{h} (nearest neighbour)")
    pose_out = np.stack([good_poses[j] for j in kept])
    return SourceFrames(
        source=source,
        src=src,
        names=[names[ok[j]] for j in kept],
        rgb=store.rgb,
        depth=store.depth,
        K=K_out,
        world_from_cam=pose_out,
        masks=store.masks,
        store=store,
        dropped=sorted(dropped, key=lambda d: d.frame),
        notes=notes,
        frames_in_source=frames_in_source or len(poses),
    )


def mask_id_counts(masks: NDArray[np.integer] | FrameData, where: Path | str) -> NDArray[np.int64]:
    """Pixels per instance id over every frame, [max id + 1] int64, read a slab of frames at a time; an
    ImportInputError naming ``where`` for ids outside 0..2^31-1."""
    counts = np.zeros(1, np.int64)
    for _, slab in iter_slabs(masks):
        if not slab.size:
            continue
        lo, hi = int(slab.min()), int(slab.max())
        if lo < 0 or hi > np.iinfo(np.int32).max:
            raise ImportInputError(
                f"{where}: instance ids outside 0..2^31-1 (min {lo}, max {hi}); renumber the instance PNGs"
            )
        c = np.bincount(slab.ravel())
        if len(c) > len(counts):
            c[: len(counts)] += counts
            counts = c
        else:
            counts[: len(c)] += c
    return counts


def _safe_median(path: Path) -> float | None:
    try:
        return raw_depth_median(path)
    except ImportInputError:
        return None


def scale_intrinsics(K: NDArray, w0: int, h0: int, w1: int, h1: int) -> NDArray[np.float64]:
    """K of an image resized from w0 x h0 to w1 x h1 (the project's renderer casts pixel u through
    u + 0.5, so the principal point scales with the image)."""
    sx, sy = w1 / w0, h1 / h0
    out = np.asarray(K, np.float64).copy()
    out[0, :] *= sx
    out[1, :] *= sy
    return out


def resize(img: NDArray, w: int, h: int, nearest: bool) -> NDArray:
    """Resize an image [H, W] or [H, W, C] to w x h (nearest for depth and ids, bilinear for colour)."""

    if nearest:
        ys = np.minimum(((np.arange(h) + 0.5) * img.shape[0] / h).astype(np.int64), img.shape[0] - 1)
        xs = np.minimum(((np.arange(w) + 0.5) * img.shape[1] / w).astype(np.int64), img.shape[1] - 1)
        return img[ys[:, None], xs[None, :]]
    return np.asarray(Image.fromarray(img).resize((w, h), Image.Resampling.BILINEAR))
