"""The capture format: a Zarr v3 group holding frames, cameras, panoptic masks and instance point clouds.

Layout (docs/capture-format.md is the user-facing description):

    attrs               format="rescene-capture", version, scene_id, units="m", up="+z", source, instances
    frames/rgb          uint8   [T, H, W, 3]
    frames/K            float64 [T, 3, 3]   pinhole intrinsics, pixels
    frames/world_from_cam float64 [T, 4, 4] camera poses, OpenCV camera axes, metres
    frames/instance     int32   [T, H, W]   panoptic id per pixel, 0 = none
    frames/depth        float32 [T, H, W]   optional metric depth along camera z, 0 = invalid
    instances/ids       int32   [N]
    instances/offsets   int64   [N + 1]     CSR offsets into points/colors
    instances/points    float32 [M, 3]      world frame, metres
    instances/colors    uint8   [M, 3]
    gt/...                                  ground truth (synthetic captures only)

Writing is atomic: the group is built in a sibling temporary directory and renamed into place. The
writer stamps the store with its content hash (``rescene_core.capture.identity``).
Reading is lazy for the per-pixel arrays (zarr arrays, one chunk per frame) and eager for the rest.

The per-pixel arrays of a ``CaptureArrays`` may be numpy arrays or frames kept on disk (``FrameStore``, an
importer's staging store, and ``FrameMap``, such frames changed slab by slab as they are read): the writer
copies them ``FRAME_SLAB`` frames at a time, and takes a staged array's encoded chunk files as they are
(hard links where the file system allows) when its chunks and codecs are the capture's, so an import of any
length holds a few frames in memory, never the whole capture.
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import zarr
from numpy.typing import NDArray

from rescene_core.capture.identity import stamp_capture
from rescene_core.io import atomic_directory
from rescene_core.records import Camera, Instance, InstanceId, InstancePoints

FORMAT_NAME = "rescene-capture"
FORMAT_VERSION = 1
FRAME_SLAB = 16
"""Frames the writer copies at a time from frames that are not in memory (16 640x480 frames: 55 MB)."""


class FrameData(Protocol):
    """A per-pixel array of T frames that can be sliced along its first axis: a numpy array, a zarr array,
    ``StoredFrames`` or ``FrameMap``. ``frames[a:b]`` (or ``frames[t]``) gives a numpy array."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    @property
    def dtype(self) -> Any: ...

    def __getitem__(self, key: Any) -> Any: ...


class StoredFrames:
    """A per-pixel zarr array of T frames read as numpy: ``frames[t]`` or ``frames[a:b]`` decodes only those
    frames; ``len``, ``shape``, ``dtype`` and ``ndim`` as a numpy array's; ``np.asarray(frames)`` reads all."""

    def __init__(self, array: zarr.Array):
        self.array = array

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(n) for n in self.array.shape)

    @property
    def dtype(self) -> np.dtype[Any]:
        return np.dtype(self.array.dtype)

    @property
    def ndim(self) -> int:
        return len(self.array.shape)

    def __len__(self) -> int:
        return int(self.array.shape[0])

    def __getitem__(self, key: Any) -> Any:
        return np.asarray(self.array[key])

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        out = np.asarray(self.array[...])
        return out if dtype is None else out.astype(dtype, copy=False)


class FrameMap:
    """Frames of ``base`` passed through ``fn`` (numpy [n, ...] -> the same shape and ``dtype``) as they are
    read, a slab at a time: e.g. masks with some ids cleared, without a second copy of every frame."""

    def __init__(self, base: FrameData, fn: Callable[[NDArray[Any]], NDArray[Any]], dtype: Any = None):
        self.base = base
        self.fn = fn
        self._dtype = np.dtype(dtype if dtype is not None else base.dtype)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(int(n) for n in self.base.shape)

    @property
    def dtype(self) -> np.dtype[Any]:
        return self._dtype

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, (int, np.integer)):
            return self.fn(np.asarray(self.base[int(key) : int(key) + 1]))[0]
        if isinstance(key, slice) and key.step in (None, 1):
            return self.fn(np.asarray(self.base[key]))
        raise TypeError(f"FrameMap is read by frame or by a slice of frames, not {key!r}")

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        out = self[0 : self.shape[0]]
        return out if dtype is None else out.astype(dtype, copy=False)


def iter_slabs(frames: FrameData, slab: int = FRAME_SLAB) -> Any:
    """(start, numpy frames [n, ...]) of ``frames`` in order, ``slab`` frames at a time."""
    n = int(frames.shape[0])
    for a in range(0, n, slab):
        yield a, np.asarray(frames[a : min(a + slab, n)])


STORE_PREFIX = "rescene-frames-"
STORE_OWNER = "owner"
"""The file in a frame store naming the host and process that made it ("HOST PID")."""


def remove_orphaned_stores(dir: str | Path | None = None) -> list[Path]:
    """Remove the frame stores in ``dir`` (default ``$TMPDIR``) whose import was killed: made on this host by
    a process that is gone (an import stopped by SIGKILL or the machine's OOM killer cannot remove its own).
    Stores of live processes, of other hosts and without an owner file are left. Returns those removed."""
    root = Path(dir) if dir is not None else Path(tempfile.gettempdir())
    host, removed = socket.gethostname(), []
    for store in root.glob(f"{STORE_PREFIX}*"):
        try:
            owner_host, pid = (store / STORE_OWNER).read_text().split()
            if owner_host != host or _alive(int(pid)):
                continue
        except (OSError, ValueError):
            continue
        shutil.rmtree(store, ignore_errors=True)
        removed.append(store)
    return removed


def _alive(pid: int) -> bool:
    """Whether a process with this id runs on this host (one of another user's counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class FrameStore:
    """Frames written into a temporary zarr group as they are read, one chunk per frame (the capture's own
    chunks and codec), so an importer holds a few frames at a time; the capture writer takes the encoded
    chunks over without decoding them. The directory is removed when the store is garbage-collected (or
    ``close``); ``dir``: where to put it (default: the system's temporary directory, ``$TMPDIR``).

    rgb uint8 [T, H, W, 3], depth float32 [T, H, W] (``has_depth``), masks int32 [T, H, W] (``has_masks``),
    each a ``StoredFrames``; ``truncate(n)`` keeps the first n frames (frames that could not be read);
    ``new_masks()`` starts an empty mask array for masks made later (a labelled mesh rendered into it)."""

    def __init__(
        self, frames: int, height: int, width: int, has_depth: bool, has_masks: bool, dir: str | Path | None = None
    ):
        remove_orphaned_stores(dir)
        self.path = Path(tempfile.mkdtemp(prefix=STORE_PREFIX, dir=dir))
        self._cleanup = weakref.finalize(self, shutil.rmtree, str(self.path), True)
        (self.path / STORE_OWNER).write_text(f"{socket.gethostname()} {os.getpid()}\n")
        self._group = zarr.open_group(str(self.path), mode="w", zarr_format=3)
        t, h, w = int(frames), int(height), int(width)
        self.rgb = self._make("rgb", (t, h, w, 3), np.uint8)
        self.depth = self._make("depth", (t, h, w), np.float32) if has_depth else None
        self.masks = self._make("instance", (t, h, w), np.int32) if has_masks else None

    def _make(self, name: str, shape: tuple[int, ...], dtype: Any) -> StoredFrames:
        # chunk files side by side ("c.5.0.0.0"), not a folder per frame: removing 850 nested folders took
        # 2.6 s on this machine's disk, the same number of files in one folder 20 ms
        arr = self._group.create_array(
            name,
            shape=shape,
            dtype=dtype,
            chunks=(1, *shape[1:]),
            compressors=[_codec()],
            chunk_key_encoding={"name": "default", "separator": "."},
        )
        return StoredFrames(arr)

    def new_masks(self) -> StoredFrames:
        """An empty (all 0) int32 mask array [T, H, W] for masks made after reading (e.g. rendered from a
        labelled mesh), replacing any there was; fill it with ``masks.array[a:b] = ...``."""
        t, h, w = self.rgb.shape[:3]
        if "instance" in self._group:
            del self._group["instance"]
        self.masks = self._make("instance", (t, h, w), np.int32)
        return self.masks

    def write(
        self, start: int, rgb: NDArray[np.uint8], depth: NDArray[np.float32] | None, masks: NDArray[np.int32] | None
    ) -> None:
        """Frames start .. start + len(rgb) - 1 (numpy [n, H, W(, 3)])."""
        stop = start + len(rgb)
        self.rgb.array[start:stop] = rgb
        if self.depth is not None and depth is not None:
            self.depth.array[start:stop] = depth
        if self.masks is not None and masks is not None:
            self.masks.array[start:stop] = masks

    def truncate(self, frames: int) -> None:
        for stored in (self.rgb, self.depth, self.masks):
            if stored is not None and stored.shape[0] != frames:
                stored.array.resize((frames, *stored.shape[1:]))

    def close(self) -> None:
        self._cleanup()


@dataclass(frozen=True)
class CaptureArrays:
    """An in-memory capture, as importers and the synthetic generator build it before writing.

    rgb: uint8 [T, H, W, 3]. K: float64 [T, 3, 3]. world_from_cam: float64 [T, 4, 4].
    instance_masks: int32 [T, H, W] (0 = none). depth: float32 [T, H, W] metres along z, or None.
    The per-pixel arrays (rgb, instance_masks, depth) may be frames on disk (``FrameData``); the writer
    reads them a slab at a time.
    instances: one record per id appearing in masks or point clouds.
    point_ids: int32 [N]; point_offsets: int64 [N + 1]; points: float32 [M, 3]; colors: uint8 [M, 3].
    """

    scene_id: str
    rgb: NDArray[np.uint8] | FrameData
    K: NDArray[np.float64]
    world_from_cam: NDArray[np.float64]
    instance_masks: NDArray[np.int32] | FrameData
    instances: tuple[Instance, ...]
    point_ids: NDArray[np.int32]
    point_offsets: NDArray[np.int64]
    points: NDArray[np.float32]
    colors: NDArray[np.uint8]
    depth: NDArray[np.float32] | FrameData | None = None
    source: str = "unknown"
    extra_attrs: dict[str, Any] = field(default_factory=dict)


def points_to_csr(
    clouds: dict[int, tuple[NDArray, NDArray]],
) -> tuple[NDArray[np.int32], NDArray[np.int64], NDArray[np.float32], NDArray[np.uint8]]:
    """Concatenate per-instance (points [n, 3], colors [n, 3]) into CSR arrays, ids ascending."""
    ids = np.array(sorted(clouds), dtype=np.int32)
    counts = [len(clouds[int(i)][0]) for i in ids]
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    if len(ids):
        pts = np.concatenate([np.asarray(clouds[int(i)][0], np.float32).reshape(-1, 3) for i in ids])
        cols = np.concatenate([np.asarray(clouds[int(i)][1], np.uint8).reshape(-1, 3) for i in ids])
    else:
        pts, cols = np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8)
    return ids, offsets, pts, cols


def _codec():
    return zarr.codecs.BloscCodec(cname="zstd", clevel=3, shuffle=zarr.codecs.BloscShuffle.bitshuffle)


def write_array(group: zarr.Group, name: str, data: NDArray, chunks: tuple[int, ...] | None = None) -> None:
    """Write one compressed array into ``group`` (chunks default to the whole array)."""
    data = np.ascontiguousarray(data)
    if chunks is None:
        chunks = tuple(max(1, s) for s in data.shape)
    arr = group.create_array(name, shape=data.shape, dtype=data.dtype, chunks=chunks, compressors=[_codec()])
    if data.size:
        arr[...] = data


def write_frames(group: zarr.Group, name: str, data: NDArray[Any] | FrameData) -> None:
    """Write a per-pixel array of T frames [T, H, W(, C)] into ``group`` with one chunk per frame.

    A numpy array is written at once. Frames on disk are copied ``FRAME_SLAB`` frames at a time, and a
    ``StoredFrames`` whose zarr metadata (shape, dtype, chunks, codecs) is the new array's gives its
    encoded chunk files as they are: hard links (copies across file systems), nothing decoded."""
    if isinstance(data, np.ndarray):
        write_array(group, name, data, (1, *data.shape[1:]))
        return
    shape = tuple(int(n) for n in data.shape)
    arr = group.create_array(
        name, shape=shape, dtype=np.dtype(data.dtype), chunks=(1, *shape[1:]), compressors=[_codec()]
    )
    if isinstance(data, StoredFrames) and _take_chunks(data.array, arr):
        return
    for a, slab in iter_slabs(data):
        arr[a : a + len(slab)] = slab


def _take_chunks(src: zarr.Array, dst: zarr.Array) -> bool:
    """Hard-link (else copy) the chunk files of ``src`` (a ``FrameStore`` array: chunk keys "c.i.j.k") into
    the empty array ``dst`` under its own chunk keys, when both live in local directories and their
    metadata agree but for the key encoding (the same encoded bytes mean the same frames); False otherwise."""
    if not (isinstance(src.store, zarr.storage.LocalStore) and isinstance(dst.store, zarr.storage.LocalStore)):
        return False
    a, b = src.metadata.to_dict(), dst.metadata.to_dict()
    a.pop("chunk_key_encoding", None)
    b.pop("chunk_key_encoding", None)
    if a != b or src.metadata.chunk_key_encoding.to_dict() != {  # type: ignore[union-attr]
        "name": "default",
        "configuration": {"separator": "."},
    }:
        return False
    src_dir = Path(src.store.root) / src.path
    dst_dir = Path(dst.store.root) / dst.path
    for entry in os.scandir(src_dir):
        parts = entry.name.split(".")
        if parts[0] != "c" or not all(p.isdigit() for p in parts[1:]) or len(parts) != len(dst.shape) + 1:
            continue
        target = dst_dir / dst.metadata.encode_chunk_key(tuple(int(p) for p in parts[1:]))  # type: ignore[union-attr]
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(entry.path, target)
        except OSError:
            shutil.copy2(entry.path, target)
    return True


def write_capture(
    path: str | Path,
    capture: CaptureArrays,
    extra: Callable[[zarr.Group], None] | None = None,
    overwrite: bool = False,
) -> Path:
    """Write ``capture`` as a Zarr v3 group at ``path``, atomically.

    extra: called with the root group before the rename, e.g. to add the ``gt/`` group.
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True or choose another path")
    with atomic_directory(path) as tmp:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        root.attrs.update(
            {
                "format": FORMAT_NAME,
                "version": FORMAT_VERSION,
                "scene_id": capture.scene_id,
                "units": "m",
                "up": "+z",
                "source": capture.source,
                "instances": [inst.to_json() for inst in capture.instances],
                **capture.extra_attrs,
            }
        )
        frames = root.create_group("frames")
        write_frames(frames, "rgb", capture.rgb)
        write_array(frames, "K", capture.K)
        write_array(frames, "world_from_cam", capture.world_from_cam)
        write_frames(frames, "instance", capture.instance_masks)
        if capture.depth is not None:
            write_frames(frames, "depth", capture.depth)
        inst = root.create_group("instances")
        write_array(inst, "ids", capture.point_ids)
        write_array(inst, "offsets", capture.point_offsets)
        write_array(inst, "points", capture.points, (max(1, min(len(capture.points), 1 << 20)), 3))
        write_array(inst, "colors", capture.colors, (max(1, min(len(capture.colors), 1 << 20)), 3))
        if extra is not None:
            extra(root)
        # the identity stamp covers every array, so runs can check the capture without reading it all
        stamp_capture(tmp)
    return path


class Capture:
    """A capture opened for reading (use ``rescene_core.capture.open_capture``, which validates).

    Per-pixel arrays stay on disk (zarr arrays; index them per frame). Cameras, the instance table and
    the CSR point cloud arrays are loaded into memory.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.root = zarr.open_group(str(self.path), mode="r")
        self.attrs: dict[str, Any] = dict(self.root.attrs)
        self.scene_id: str = str(self.attrs.get("scene_id", self.path.stem))
        self.source: str = str(self.attrs.get("source", "unknown"))
        self.instances: tuple[Instance, ...] = tuple(Instance.from_json(d) for d in self.attrs["instances"])
        frames = self.root["frames"]
        self.rgb: zarr.Array = frames["rgb"]
        self.instance_masks: zarr.Array = frames["instance"]
        self.depth: zarr.Array | None = frames["depth"] if "depth" in frames else None
        self.K: NDArray[np.float64] = np.asarray(frames["K"][...], dtype=np.float64)
        self.world_from_cam: NDArray[np.float64] = np.asarray(frames["world_from_cam"][...], dtype=np.float64)
        inst = self.root["instances"]
        self.point_ids: NDArray[np.int32] = np.asarray(inst["ids"][...])
        self.point_offsets: NDArray[np.int64] = np.asarray(inst["offsets"][...])
        self._points = inst["points"]
        self._colors = inst["colors"]
        self._row = {int(i): r for r, i in enumerate(self.point_ids)}

    @property
    def num_frames(self) -> int:
        return int(self.instance_masks.shape[0])

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return int(self.instance_masks.shape[2]), int(self.instance_masks.shape[1])

    @property
    def has_gt(self) -> bool:
        return "gt" in self.root

    def instance(self, instance_id: int) -> Instance:
        for inst in self.instances:
            if inst.id == instance_id:
                return inst
        raise KeyError(f"instance {instance_id} is not in {self.path}")

    @property
    def object_instances(self) -> tuple[Instance, ...]:
        """Non-structural instances (the objects that get assets), in table order."""
        return tuple(i for i in self.instances if not i.structural)

    def camera(self, frame: int) -> Camera:
        w, h = self.image_size
        return Camera(self.K[frame], self.world_from_cam[frame], w, h)

    def cameras(self) -> list[Camera]:
        return [self.camera(t) for t in range(self.num_frames)]

    def point_cloud(self, instance_id: int) -> InstancePoints:
        """P_i of one instance (empty arrays when it has none)."""
        row = self._row.get(int(instance_id))
        if row is None:
            return InstancePoints(
                InstanceId(int(instance_id)), np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8)
            )
        a, b = int(self.point_offsets[row]), int(self.point_offsets[row + 1])
        return InstancePoints(
            InstanceId(int(instance_id)), np.asarray(self._points[a:b]), np.asarray(self._colors[a:b])
        )

    def all_points(self) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        """Every instance point [M, 3] and its instance id [M]."""
        pts = np.asarray(self._points[...])
        counts = np.diff(self.point_offsets)
        return pts, np.repeat(self.point_ids, counts).astype(np.int32)

    def summary(self) -> dict[str, Any]:
        """A short description for people: sizes, counts, labels."""
        w, h = self.image_size
        labels: dict[str, int] = {}
        for inst in self.instances:
            labels[inst.label] = labels.get(inst.label, 0) + 1
        return {
            "path": str(self.path),
            "scene_id": self.scene_id,
            "source": self.source,
            "frames": self.num_frames,
            "image_size": [w, h],
            "has_depth": self.depth is not None,
            "instances": len(self.instances),
            "objects": len(self.object_instances),
            "points": int(self.point_offsets[-1]) if len(self.point_offsets) else 0,
            "labels": dict(sorted(labels.items())),
            "has_ground_truth": self.has_gt,
        }
