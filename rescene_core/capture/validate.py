"""Validation of a capture on disk: every problem found, each naming the array, the field and the fix.

``check_capture`` never raises for bad data: it returns problems. ``open_capture`` raises
``CaptureError`` (listing all of them) when any is an error, and returns a ``Capture`` otherwise.
``check_capture`` decodes every chunk of every array first (``check_chunks``), so a chunk whose bytes no
longer decode is named by its array and frame; ``check_identity`` compares the store's files with the
identity stamp written into it (``rescene_core.capture.identity``), which also catches bytes that changed
and still decode.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import zarr

from rescene_core.capture.format import FORMAT_NAME, FORMAT_VERSION, Capture
from rescene_core.capture.identity import IDENTITY_ATTR, CaptureChangedError, capture_identity

ROTATION_TOLERANCE = 1e-4
"""Largest |R^T R - I| entry and |det R - 1| accepted for a camera rotation."""


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a capture: where (array or attribute), what, and how to fix it."""

    where: str
    message: str
    fix: str
    severity: Literal["error", "warning"] = "error"

    def __str__(self) -> str:
        return f"[{self.severity}] {self.where}: {self.message} (fix: {self.fix})"


class CaptureError(ValueError):
    """A capture that cannot be used; ``problems`` lists every problem found."""

    def __init__(self, path: str | Path, problems: list[Problem]):
        self.path = Path(path)
        self.problems = problems
        errors = [p for p in problems if p.severity == "error"]
        lines = "\n".join(f"  - {p}" for p in errors)
        super().__init__(f"{self.path}: {len(errors)} problem(s) in the capture:\n{lines}")


class _Checker:
    def __init__(self, path: Path):
        self.path = path
        self.problems: list[Problem] = []

    def error(self, where: str, message: str, fix: str) -> None:
        self.problems.append(Problem(where, message, fix))

    def warn(self, where: str, message: str, fix: str) -> None:
        self.problems.append(Problem(where, message, fix, "warning"))

    def array(self, group: Any, name: str, dtype: str, ndim: int, required: bool = True) -> np.ndarray | None:
        """The array ``group/name`` read into memory when its dtype and rank are right, else None."""
        where = f"{group.path}/{name}" if group.path else name
        if name not in group:
            if required:
                self.error(where, "array is missing", f"write a {dtype} array with {ndim} dimensions at {where}")
            return None
        node = group[name]
        if not isinstance(node, zarr.Array):
            self.error(where, "is a group, not an array", f"write a {dtype} array at {where}")
            return None
        ok = True
        if str(node.dtype) != dtype:
            self.error(where, f"dtype is {node.dtype}", f"store it as {dtype}")
            ok = False
        if node.ndim != ndim:
            self.error(where, f"has {node.ndim} dimensions, shape {node.shape}", f"give it {ndim} dimensions")
            ok = False
        return node if ok else None


def _check_attrs(c: _Checker, root: zarr.Group) -> list[dict[str, Any]]:
    attrs = dict(root.attrs)
    if attrs.get("format") != FORMAT_NAME:
        c.error("attrs.format", f"is {attrs.get('format')!r}", f"set attrs['format'] = {FORMAT_NAME!r}")
    if attrs.get("version") != FORMAT_VERSION:
        c.error("attrs.version", f"is {attrs.get('version')!r}", f"set attrs['version'] = {FORMAT_VERSION}")
    if not isinstance(attrs.get("scene_id"), str) or not attrs.get("scene_id"):
        c.error("attrs.scene_id", "is missing or not a non-empty string", "set attrs['scene_id'] to a name")
    if attrs.get("units") != "m":
        c.error("attrs.units", f"is {attrs.get('units')!r}", "store metres and set attrs['units'] = 'm'")
    if attrs.get("up") != "+z":
        c.error("attrs.up", f"is {attrs.get('up')!r}", "rotate the world so z is up and set attrs['up'] = '+z'")
    table = attrs.get("instances")
    if not isinstance(table, list):
        c.error("attrs.instances", "is missing or not a list", "set a list of {id, label, structural} records")
        return []
    good: list[dict[str, Any]] = []
    seen: set[int] = set()
    for k, rec in enumerate(table):
        where = f"attrs.instances[{k}]"
        if not isinstance(rec, dict):
            c.error(where, "is not an object", "use {id, label, structural}")
            continue
        iid, label = rec.get("id"), rec.get("label")
        if isinstance(iid, bool) or not isinstance(iid, int) or iid <= 0:
            c.error(f"{where}.id", f"is {iid!r}", "use a positive integer id (0 means 'no instance')")
            continue
        if not isinstance(label, str) or not label.strip():
            c.error(f"{where}.label", f"is {label!r}", "give a category name such as 'chair'")
            continue
        if not isinstance(rec.get("structural", False), bool):
            c.error(f"{where}.structural", f"is {rec.get('structural')!r}", "use true or false")
            continue
        if iid in seen:
            c.error(f"{where}.id", f"id {iid} appears twice", "give each instance one record")
            continue
        seen.add(iid)
        good.append(rec)
    return good


def _check_cameras(
    c: _Checker, K: np.ndarray | None, pose: np.ndarray | None, n_frames: int, size: tuple[int, int] | None
) -> None:
    if K is not None:
        if K.shape[1:] != (3, 3):
            c.error("frames/K", f"shape is {K.shape}", "store one 3x3 matrix per frame: [T, 3, 3]")
        else:
            K = np.asarray(K[...])
            bad = np.flatnonzero(~np.isfinite(K).all(axis=(1, 2)))
            if len(bad):
                c.error(
                    "frames/K",
                    f"NaN or infinite values in frames {bad[:10].tolist()}",
                    "write finite intrinsics",
                )
            finite = np.isfinite(K).all(axis=(1, 2))
            not_pinhole = np.flatnonzero(
                finite
                & (
                    (np.abs(K[:, 2] - [0, 0, 1]).max(axis=1) > 1e-9)
                    | (np.abs(K[:, 0, 1]) > 1e-9)
                    | (np.abs(K[:, 1, 0]) > 1e-9)
                    | (K[:, 0, 0] <= 0)
                    | (K[:, 1, 1] <= 0)
                )
            )
            if len(not_pinhole):
                c.error(
                    "frames/K",
                    f"not a pinhole matrix in frames {not_pinhole[:10].tolist()}",
                    "use [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0 and zero skew (undistort first)",
                )
            if size is not None:
                w, h = size
                off = np.flatnonzero(
                    finite & ((K[:, 0, 2] < 0) | (K[:, 0, 2] > w) | (K[:, 1, 2] < 0) | (K[:, 1, 2] > h))
                )
                if len(off):
                    c.error(
                        "frames/K",
                        f"principal point outside the image in frames {off[:10].tolist()}",
                        "cx, cy are pixels inside the image",
                    )
            if K.shape[0] != n_frames:
                c.error("frames/K", f"has {K.shape[0]} frames, masks have {n_frames}", "write one K per frame")
    if pose is not None:
        if pose.shape[1:] != (4, 4):
            c.error("frames/world_from_cam", f"shape is {pose.shape}", "store one 4x4 matrix per frame: [T, 4, 4]")
            return
        pose = np.asarray(pose[...])
        if pose.shape[0] != n_frames:
            c.error(
                "frames/world_from_cam",
                f"has {pose.shape[0]} frames, masks have {n_frames}",
                "write one pose per frame",
            )
        finite = np.isfinite(pose).all(axis=(1, 2))
        bad = np.flatnonzero(~finite)
        if len(bad):
            c.error(
                "frames/world_from_cam",
                f"NaN or infinite values in frames {bad[:10].tolist()}",
                "write finite poses",
            )
        p = np.where(finite[:, None, None], pose, np.eye(4))
        rot = p[:, :3, :3]
        orth = np.abs(np.einsum("tji,tjk->tik", rot, rot) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(rot)
        not_rot = np.flatnonzero((orth > ROTATION_TOLERANCE) | (np.abs(det - 1) > ROTATION_TOLERANCE))
        if len(not_rot):
            c.error(
                "frames/world_from_cam",
                f"upper-left 3x3 is not a rotation in frames {not_rot[:10].tolist()}",
                "store rigid camera-to-world poses (orthonormal, det +1, no scale)",
            )
        last = np.flatnonzero(np.abs(p[:, 3] - [0, 0, 0, 1]).max(axis=1) > 1e-9)
        if len(last):
            c.error(
                "frames/world_from_cam",
                f"last row is not [0, 0, 0, 1] in frames {last[:10].tolist()}",
                "use homogeneous 4x4 matrices",
            )


def _arrays(group: zarr.Group, prefix: str = "") -> Iterator[tuple[str, zarr.Array]]:
    """Every array under ``group``, by its path in the store, depth first in name order."""
    for name, node in sorted(group.members(), key=lambda m: m[0]):
        if isinstance(node, zarr.Array):
            yield f"{prefix}{name}", node
        else:
            yield from _arrays(node, f"{prefix}{name}/")


def _span(path: str, array: zarr.Array, rows: list[tuple[int, int]]) -> str:
    """The frames (or rows) that chunks along the first axis hold, for people: ``frames 3, 17``."""
    per_frame = path.startswith("frames/") or (array.ndim >= 3 and array.chunks[0] == 1)
    word = "frame" if per_frame else "row"
    parts = [str(a) if b == a else f"{a}-{b}" for a, b in rows[:10]]
    more = f" and {len(rows) - 10} more" if len(rows) > 10 else ""
    return f"{word}{'s' if len(rows) > 1 or rows[0][1] > rows[0][0] else ''} {', '.join(parts)}{more}"


def check_chunks(path: str | Path) -> list[Problem]:
    """Decode every chunk of every array of the store at ``path``; one error per array whose chunks do
    not decode (bytes that no longer decode: a disk or copy fault), naming the frames (or rows) they hold
    and their chunk files. Costs one read of the store (0.5 s for the 170 MB standard synthetic capture)."""
    problems: list[Problem] = []
    root = zarr.open_group(str(path), mode="r")
    for name, array in _arrays(root):
        if array.size == 0:
            continue
        grid = [math.ceil(n / c) for n, c in zip(array.shape, array.chunks)]
        rows: list[tuple[int, int]] = []
        files: list[str] = []
        first_error = ""
        for index in itertools.product(*(range(g) for g in grid)):
            region = tuple(slice(i * c, min((i + 1) * c, n)) for i, c, n in zip(index, array.chunks, array.shape))
            try:
                array[region]
            except Exception as err:  # noqa: BLE001 - codecs raise many types for bytes they cannot decode
                first_error = first_error or f"{type(err).__name__}: {err}"
                rows.append((region[0].start, region[0].stop - 1))
                files.append(f"{name}/{array.metadata.encode_chunk_key(index)}")
        if rows:
            listed = ", ".join(files[:5]) + (" ..." if len(files) > 5 else "")
            problems.append(
                Problem(
                    name,
                    f"{_span(name, array, sorted(set(rows)))} cannot be decoded ({len(files)} chunk(s): {listed}; "
                    f"{first_error})",
                    "the chunk's bytes are damaged: restore the capture from a copy, or write it again "
                    "(rescene synth / rescene import)",
                )
            )
    return problems


def check_identity(path: str | Path, full: bool = False) -> list[Problem]:
    """The capture's files against its identity stamp, as ``rescene run`` checks them: cheaply (sizes,
    and the files modified since the stamp rehashed) or, with ``full``, every file rehashed, which also
    finds bytes that changed in place without a new modification time. A capture without a stamp gets
    a warning (runs then hash it whole)."""
    if not zarr.open_group(str(path), mode="r").attrs.get(IDENTITY_ATTR):
        return [
            Problem(
                "attrs.identity",
                "the capture has no identity stamp: every run hashes the whole store",
                "stamp it once: rescene_core.capture.identity.stamp_capture(PATH)",
                "warning",
            )
        ]
    try:
        capture_identity(path, full=full)
    except CaptureChangedError as err:
        detail = str(err).split(": ", 1)[-1].split(". ", 1)
        return [Problem("attrs.identity", detail[0], detail[1] if len(detail) > 1 else "write the capture again")]
    return []


def check_capture(path: str | Path) -> list[Problem]:
    """Every problem of the capture at ``path`` (errors and warnings); an empty list for a clean capture.

    Every chunk is decoded first (``check_chunks``); when some do not decode, the attributes are checked
    but not the arrays' content, which those chunks are part of."""
    path = Path(path)
    c = _Checker(path)
    if not path.exists():
        c.error(
            str(path),
            "does not exist",
            "pass the path of a capture written by `rescene synth` or an importer",
        )
        return c.problems
    try:
        root = zarr.open_group(str(path), mode="r")
    except Exception as err:  # zarr raises several types for "not a group"
        c.error(str(path), f"is not a Zarr group ({type(err).__name__})", "pass a *.zarr capture directory")
        return c.problems
    try:
        undecodable = check_chunks(path)
        if undecodable:
            c.problems.extend(undecodable)
            _check_attrs(c, root)
            return c.problems
        _check_all(c, root)
    except Exception as err:  # unreadable metadata and the like: reported, never a traceback
        c.error(str(path), f"could not be read: {type(err).__name__}: {err}", "rewrite the capture")
    return c.problems


def _check_all(c: _Checker, root: zarr.Group) -> None:
    table = _check_attrs(c, root)
    table_ids = {int(r["id"]) for r in table}
    structural = {int(r["id"]) for r in table if r.get("structural")}
    if "frames" not in root or not isinstance(root["frames"], zarr.Group):
        c.error("frames", "group is missing", "write frames/{rgb, K, world_from_cam, instance}")
        return
    frames = root["frames"]
    masks = c.array(frames, "instance", "int32", 3)
    rgb = c.array(frames, "rgb", "uint8", 4)
    K = c.array(frames, "K", "float64", 3)
    pose = c.array(frames, "world_from_cam", "float64", 3)
    depth = c.array(frames, "depth", "float32", 3, required=False)
    n_frames, size = 0, None
    if masks is not None:
        n_frames, h, w = masks.shape
        size = (w, h)
        if n_frames == 0:
            c.error("frames/instance", "has no frames", "write at least one frame")
    if rgb is not None and masks is not None and rgb.shape != (*masks.shape, 3):
        c.error(
            "frames/rgb",
            f"shape {rgb.shape} does not match masks {masks.shape}",
            "store [T, H, W, 3] with the masks' T, H, W",
        )
    if depth is not None and masks is not None and depth.shape != masks.shape:
        c.error(
            "frames/depth",
            f"shape {depth.shape} does not match masks {masks.shape}",
            "store [T, H, W] with the masks' T, H, W",
        )
    _check_cameras(c, K, pose, n_frames, size)

    mask_ids: set[int] = set()
    if masks is not None:
        for t in range(n_frames):
            ids = np.unique(np.asarray(masks[t]))
            mask_ids.update(int(i) for i in ids)
        negative = sorted(i for i in mask_ids if i < 0)
        if negative:
            c.error(
                "frames/instance",
                f"negative ids {negative[:10]}",
                "use 0 for 'no instance' and positive ids otherwise",
            )
        unknown = sorted(i for i in mask_ids if i > 0 and i not in table_ids)
        if unknown:
            c.error(
                "frames/instance",
                f"ids {unknown[:20]} are not in attrs.instances",
                "add a record for each id or clear those pixels to 0",
            )
        unseen = sorted(i for i in table_ids if i not in mask_ids and i not in structural)
        if unseen:
            c.warn(
                "attrs.instances",
                f"instances {unseen[:20]} appear in no mask",
                "they will be recorded as missing; drop them or add their masks",
            )
    if depth is not None:
        bad = [t for t in range(depth.shape[0]) if not np.isfinite(np.asarray(depth[t])).all()]
        if bad:
            c.warn(
                "frames/depth",
                f"NaN or infinite depth in frames {bad[:10]}",
                "write 0 for invalid depth (it is treated as invalid)",
            )
        neg = [t for t in range(depth.shape[0]) if (np.asarray(depth[t]) < 0).any()]
        if neg:
            c.error(
                "frames/depth",
                f"negative depth in frames {neg[:10]}",
                "store metric depth along camera z, 0 for invalid",
            )

    _check_points(c, root, table_ids, structural)


def _check_points(c: _Checker, root: zarr.Group, table_ids: set[int], structural: set[int]) -> None:
    if "instances" not in root or not isinstance(root["instances"], zarr.Group):
        c.error("instances", "group is missing", "write instances/{ids, offsets, points, colors}")
        return
    g = root["instances"]
    ids = c.array(g, "ids", "int32", 1)
    offsets = c.array(g, "offsets", "int64", 1)
    points = c.array(g, "points", "float32", 2)
    colors = c.array(g, "colors", "uint8", 2)
    if points is not None and points.shape[1] != 3:
        c.error("instances/points", f"shape is {points.shape}", "store [M, 3] xyz in metres")
        points = None
    if colors is not None and colors.shape[1] != 3:
        c.error("instances/colors", f"shape is {colors.shape}", "store [M, 3] RGB")
        colors = None
    if points is not None and colors is not None and colors.shape[0] != points.shape[0]:
        c.error(
            "instances/colors",
            f"has {colors.shape[0]} rows, points has {points.shape[0]}",
            "one colour per point",
        )
    if points is not None:
        pts = np.asarray(points[...])
        bad = int((~np.isfinite(pts).all(axis=1)).sum())
        if bad:
            c.error("instances/points", f"{bad} points have NaN or infinite coordinates", "drop those points")
    if ids is None or offsets is None:
        return
    ids_np, off = np.asarray(ids[...]), np.asarray(offsets[...])
    if len(off) != len(ids_np) + 1:
        c.error(
            "instances/offsets",
            f"has {len(off)} entries for {len(ids_np)} ids",
            "store N + 1 offsets for N ids",
        )
        return
    if len(off) and off[0] != 0:
        c.error("instances/offsets", f"starts at {off[0]}", "the first offset is 0")
    if np.any(np.diff(off) < 0):
        c.error("instances/offsets", "decreases", "offsets are cumulative point counts (non-decreasing)")
    if points is not None and len(off) and off[-1] != points.shape[0]:
        c.error(
            "instances/offsets",
            f"ends at {off[-1]} but there are {points.shape[0]} points",
            "the last offset is the number of points",
        )
    if len(set(ids_np.tolist())) != len(ids_np):
        c.error("instances/ids", "has duplicate ids", "store each instance's points once")
    unknown = sorted(int(i) for i in ids_np if int(i) not in table_ids)
    if unknown:
        c.error("instances/ids", f"ids {unknown[:20]} are not in attrs.instances", "add a record for each id")
    counts = np.diff(off)
    empty = sorted(int(i) for i, n in zip(ids_np, counts) if n == 0)
    if empty:
        c.error(
            "instances/offsets",
            f"instances {empty[:20]} have empty point clouds",
            "drop them from instances/ids or give them points",
        )
    no_cloud = sorted(i for i in table_ids - set(ids_np.tolist()) if i not in structural)
    if no_cloud:
        c.warn(
            "instances/ids",
            f"instances {no_cloud[:20]} have no point cloud",
            "they will be recorded as missing",
        )


def open_capture(path: str | Path, validate: bool = True) -> Capture:
    """Open a capture for reading; with ``validate`` raise ``CaptureError`` listing every error found."""
    if validate:
        problems = check_capture(path)
        if any(p.severity == "error" for p in problems):
            raise CaptureError(path, problems)
    try:
        return Capture(path)
    except Exception as err:
        raise CaptureError(path, [Problem(str(path), f"could not be opened: {err}", "rewrite the capture")]) from err
