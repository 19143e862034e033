"""The user cache: results that outlive a run directory, keyed by content, shared by every run of the user.

Work that depends only on its inputs and the code that made it (a CoACD decomposition of a mesh, an asset
generated from one view) is stored here under a key that hashes the content, the parameters and the code
version, so a second run of the same scene, or a split of hundreds of scenes that share furniture, never
repeats it.

    cache = UserCache("convex")                  # $RESCENE_CACHE_DIR/convex or ~/.cache/rescene/convex
    key = content_key(vertices, faces, {"threshold": 0.05}, "v1")
    data = cache.get(key, ".npz")                # bytes, or None on a miss
    cache.put(key, ".npz", data)                 # atomic; evicts the least recently used over the cap

Where: ``$RESCENE_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/rescene``, else ``~/.cache/rescene``; one
folder per namespace, entries in ``<namespace>/<first two hex digits>/<key><suffix>``.

Size: the whole cache root is capped at ``$RESCENE_CACHE_MAX_GB`` gigabytes (default
``DEFAULT_MAX_GB``); after a write that may have crossed it, the least recently used entries (by
modification time, which a hit refreshes) are deleted until the cache is at ``EVICT_TO`` of the cap.

Concurrency: several processes (a flow's task threads, parallel runs of a split, a cluster's workers on
shared storage) may read and write one cache. A write goes to a temporary file in the entry's folder and
is moved into place with ``os.replace``, so a reader sees the old entry, the new one or none, never half of
one; two writers of one key write the same content and the last rename wins. A reader reads the whole
entry at once, so an eviction between its lookup and its read is a miss, not an error. A corrupt entry
(the caller's decoder fails) is dropped with ``discard`` and computed and written again.
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.io import write_bytes_atomic

DEFAULT_MAX_GB = 10.0
"""Default size cap of the whole cache (GB, 1e9 bytes) when ``RESCENE_CACHE_MAX_GB`` is not set."""
EVICT_TO = 0.8
"""An eviction deletes least recently used entries until the cache holds at most this fraction of its cap
(so the next writes do not each trigger a sweep)."""
SWEEP_EVERY_S = 30.0
"""A process sweeps the cache for its size at most this often ..."""
SWEEP_EVERY_FRACTION = 0.05
"""... unless it has written this fraction of the cap since its last sweep."""
STALE_TEMP_S = 3600.0
"""A temporary file older than this (s) is left over from a killed writer and is deleted by a sweep."""


class CacheConfigError(ValueError):
    """A cache setting from the environment is unusable; the message names the variable and the fix."""


def cache_root() -> Path:
    """The root of the user cache: ``$RESCENE_CACHE_DIR``, ``$XDG_CACHE_HOME/rescene`` or ``~/.cache/rescene``."""
    if root := os.environ.get("RESCENE_CACHE_DIR"):
        return Path(root).expanduser()
    if xdg := os.environ.get("XDG_CACHE_HOME"):
        return Path(xdg).expanduser() / "rescene"
    return Path.home() / ".cache" / "rescene"


def max_cache_bytes() -> int:
    """The size cap in bytes from ``RESCENE_CACHE_MAX_GB`` (default ``DEFAULT_MAX_GB``)."""
    raw = os.environ.get("RESCENE_CACHE_MAX_GB")
    if raw is None or not raw.strip():
        return int(DEFAULT_MAX_GB * 1e9)
    try:
        gb = float(raw)
    except ValueError:
        gb = float("nan")
    if not gb > 0:
        raise CacheConfigError(
            f"RESCENE_CACHE_MAX_GB is {raw!r}; set it to a positive number of gigabytes (e.g. 10) or unset it"
        )
    return int(gb * 1e9)


def content_key(*parts: Any) -> str:
    """sha256 (hex) of the parts in order: numpy arrays by dtype, shape and bytes; bytes as they are;
    anything else as sorted JSON (parameters, code versions). Parts are delimited, so ('ab', 'c') and
    ('a', 'bc') differ."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            arr = np.ascontiguousarray(part)
            head = f"ndarray:{arr.dtype.str}:{arr.shape}"
            body = arr.tobytes()
        elif isinstance(part, bytes | bytearray | memoryview):
            head, body = "bytes", bytes(part)
        else:
            head, body = "json", json.dumps(part, sort_keys=True, default=str).encode()
        h.update(f"{head}:{len(body)}:".encode())
        h.update(body)
    return h.hexdigest()


@dataclass(frozen=True)
class Eviction:
    """What a sweep did: entries removed, bytes freed, bytes left, stale temporary files removed."""

    removed: int
    bytes_freed: int
    bytes_left: int
    stale_temps: int


_SWEEP_LOCK = threading.Lock()
_LAST_SWEEP: dict[Path, tuple[float, int]] = {}
"""Per cache root: (time of this process's last sweep, bytes it has written since)."""


class UserCache:
    """One namespace of the user cache (see the module doc).

    namespace: the folder under the root ('convex', 'assets'). directory: a folder to use instead of
    ``root/namespace`` (a test's, or one set in a config); the size cap then covers that folder alone.
    max_bytes: the cap (default ``max_cache_bytes()``).
    """

    def __init__(self, namespace: str, directory: str | Path | None = None, max_bytes: int | None = None):
        if not namespace or "/" in namespace or namespace.startswith("."):
            raise ValueError(f"cache namespace {namespace!r}: use a plain folder name such as 'convex'")
        self.namespace = namespace
        if directory is not None:
            self.directory = Path(directory)
            self.root = self.directory
        else:
            self.root = cache_root()
            self.directory = self.root / namespace
        self.max_bytes = max_cache_bytes() if max_bytes is None else int(max_bytes)

    def entry(self, key: str, suffix: str = "") -> Path:
        """Where the entry of ``key`` lives (it may not exist)."""
        if len(key) < 8 or not all(c in "0123456789abcdef" for c in key):
            raise ValueError(f"cache key {key!r}: use a hex digest such as content_key(...)")
        return self.directory / key[:2] / f"{key}{suffix}"

    def get(self, key: str, suffix: str = "") -> bytes | None:
        """The entry's bytes, or None when there is none (or it went between the lookup and the read).
        A hit refreshes the entry's modification time, which orders the eviction."""
        path = self.entry(key, suffix)
        try:
            data = path.read_bytes()
        except (FileNotFoundError, IsADirectoryError, PermissionError):
            return None
        try:
            os.utime(path)
        except OSError:  # evicted meanwhile, or a read-only cache: the bytes read are still good
            pass
        return data

    def put(self, key: str, suffix: str, data: bytes) -> Path | None:
        """Write the entry atomically and keep the cache under its cap; None when the cache cannot be
        written (a read-only or full disk only costs the recomputation next time)."""
        path = self.entry(key, suffix)
        try:
            write_bytes_atomic(path, data)
        except OSError:
            return None
        self._maybe_sweep(len(data))
        return path

    def discard(self, key: str, suffix: str = "") -> None:
        """Remove an entry (a corrupt one, before it is computed again)."""
        self.entry(key, suffix).unlink(missing_ok=True)

    def _maybe_sweep(self, written: int) -> None:
        now = time.monotonic()
        with _SWEEP_LOCK:
            last, since = _LAST_SWEEP.get(self.root, (-float("inf"), 0))
            since += written
            due = now - last >= SWEEP_EVERY_S or since >= SWEEP_EVERY_FRACTION * self.max_bytes
            _LAST_SWEEP[self.root] = (now, 0) if due else (last, since)
        if due:
            evict(self.root, self.max_bytes)


def _entries(root: Path) -> Iterable[os.DirEntry[str]]:
    """Every file under ``root`` (recursively), temporary files included."""
    todo = [root]
    while todo:
        folder = todo.pop()
        try:
            with os.scandir(folder) as it:
                for item in it:
                    if item.is_dir(follow_symlinks=False):
                        todo.append(Path(item.path))
                    elif item.is_file(follow_symlinks=False):
                        yield item
        except (FileNotFoundError, NotADirectoryError):
            continue


def evict(root: str | Path | None = None, max_bytes: int | None = None) -> Eviction:
    """Delete the least recently used entries under ``root`` (default: the cache root) until it holds at
    most ``EVICT_TO`` x ``max_bytes`` when it holds more than ``max_bytes``; also deletes temporary files
    of writers that died (older than ``STALE_TEMP_S``). Safe while others read and write: a file that
    disappears meanwhile is skipped."""
    root = Path(root) if root is not None else cache_root()
    cap = max_cache_bytes() if max_bytes is None else int(max_bytes)
    now = time.time()
    files: list[tuple[float, int, str]] = []
    stale = 0
    for item in _entries(root):
        try:
            st = item.stat(follow_symlinks=False)
        except FileNotFoundError:
            continue
        if item.name.startswith("."):  # a write in progress (write_bytes_atomic's temporary file)
            if now - st.st_mtime > STALE_TEMP_S:
                Path(item.path).unlink(missing_ok=True)
                stale += 1
            continue
        files.append((st.st_mtime, st.st_size, item.path))
    total = sum(size for _, size, _ in files)
    removed = freed = 0
    if total > cap:
        target = EVICT_TO * cap
        for _, size, path in sorted(files):
            if total - freed <= target:
                break
            try:
                os.unlink(path)
            except FileNotFoundError:  # another sweep took it
                pass
            removed += 1
            freed += size
    return Eviction(removed, freed, total - freed, stale)


def cache_size(root: str | Path | None = None) -> tuple[int, int]:
    """(entries, bytes) under ``root`` (default: the cache root), temporary files left out."""
    root = Path(root) if root is not None else cache_root()
    n = size = 0
    for item in _entries(root):
        if item.name.startswith("."):
            continue
        try:
            size += item.stat(follow_symlinks=False).st_size
        except FileNotFoundError:
            continue
        n += 1
    return n, size
