"""Atomic writes and content hashes for run-directory files (temp file + rename, so no half files).

A write that runs out of space (``ENOSPC``, or ``EDQUOT`` on a quota) raises ``DiskFullError`` naming the
file, the bytes it needed and what is free there; the temporary file is removed and the file it was to
replace is left as it was, so a run that fills its disk leaves every earlier output (and the cache records
that point at them) intact and resumes from them once space is freed."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} as JSON")


DISK_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)
"""The errors of a write that found no space: the device is full, or the user's quota is."""


class DiskFullError(OSError):
    """A run-directory write found no space left; the message names the file, the bytes it needed, the
    space free on its file system and the fix. The file it was to replace is unchanged."""


def free_bytes(path: str | Path) -> int:
    """Bytes free to this user on the file system holding ``path`` (its nearest existing ancestor)."""
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    st = os.statvfs(p)
    return st.f_bavail * st.f_frsize


def disk_full_error(path: str | Path, needed: int | None, exc: OSError) -> DiskFullError:
    """The ``DiskFullError`` for a write of ``needed`` bytes (None: unknown, e.g. a directory) to ``path``
    that failed with ``exc`` (an ``ENOSPC`` or ``EDQUOT`` error)."""
    size = "" if needed is None else f" ({needed} bytes)"
    return DiskFullError(
        exc.errno,
        f"no space left writing {path}{size}: {free_bytes(path)} bytes free on its file system; free space "
        f"there or move the run directory to a larger disk, then run again (finished stages are kept and "
        f"served from the cache; this file was not written)",
    )


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` via a sibling temporary file and ``os.replace``; ``DiskFullError`` when
    the file system has no room for it (``path`` then unchanged, no temporary file left)."""
    path = Path(path)
    tmp: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS:
            raise disk_full_error(path, len(data), exc) from exc
        raise
    return path


@contextmanager
def atomic_directory(path: str | Path) -> Iterator[Path]:
    """Yield a sibling temporary directory to fill; on success it replaces ``path`` (an existing directory
    there is removed first), on any error it is removed and ``path`` is left as it was (``DiskFullError``
    when its file system has no room)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    except OSError as exc:
        if exc.errno in DISK_FULL_ERRNOS:
            raise disk_full_error(path, None, exc) from exc
        raise
    try:
        yield tmp
        if path.exists():
            shutil.rmtree(path)
        os.replace(tmp, path)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS and not isinstance(exc, DiskFullError):
            raise disk_full_error(path, None, exc) from exc
        raise


def write_json_atomic(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as indented JSON (numpy arrays and scalars become lists and numbers)."""
    return write_bytes_atomic(path, json.dumps(obj, indent=2, default=_default).encode())


def read_json(path: str | Path) -> Any:
    return json.loads(Path(path).read_text())


def hash_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def hash_file(path: str | Path, chunk: int = 1 << 20) -> str:
    """sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def hash_tree(path: str | Path) -> str:
    """sha256 over a directory's relative file names and contents (e.g. a Zarr store), order-independent."""
    root = Path(path)
    h = hashlib.sha256()
    for p in sorted(q for q in root.rglob("*") if q.is_file()):
        h.update(str(p.relative_to(root)).encode())
        h.update(hash_file(p).encode())
    return h.hexdigest()
