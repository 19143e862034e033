"""Capture identity: a content hash written once into the capture, checked cheaply on every run.

Hashing every byte of a multi-GB capture on every run is slow, so the writer stamps the store once
(``stamp_capture``): ``attrs["identity"]`` holds the sha256 of every file of the store (the chunks and
array metadata; the root ``zarr.json``, which holds the stamp, is covered through its other attributes)
and one ``content_hash`` over all of them. A run then checks the stamp cheaply (``capture_identity``):
the same files with the same sizes, and every file modified after the stamp hashed again, so a capture
changed in place is detected without reading the unchanged bytes. ``full=True`` rehashes everything.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import zarr

from rescene_core.io import hash_file, hash_tree

IDENTITY_ATTR = "identity"
"""Capture attribute holding the stamp: ``{content_hash, files: {relpath: [size, sha256]}, stamped_at_ns}``."""

ROOT_METADATA = "zarr.json"
"""The root group's metadata file: it holds the stamp itself, so it is hashed through its attributes."""

Verification = Literal["stamp", "full", "unstamped"]


class CaptureChangedError(ValueError):
    """The capture's files no longer match the identity stamped into it when it was written."""


@dataclass(frozen=True)
class CaptureIdentity:
    """The content identity of a capture store.

    content_hash: sha256 hex over the store's files and attributes (stable under copying or moving).
    verification: how it was established: "stamp" (sizes checked, files modified since the stamp
    rehashed), "full" (every file rehashed against the stamp) or "unstamped" (no stamp: every byte
    hashed, as for captures written before stamps existed).
    rehashed_files: how many files were read to establish it.
    """

    content_hash: str
    verification: Verification
    rehashed_files: int


def _data_files(root: Path) -> dict[str, Path]:
    """Every file of the store by relative POSIX path, the root metadata file excluded."""
    return {rel: path for rel, (path, _) in _scan(root).items()}


def _scan(root: Path) -> dict[str, tuple[Path, os.stat_result]]:
    """Every file of the store by relative POSIX path with its stat, the root metadata file excluded: one
    pass of ``os.scandir`` (a 120-frame 640x480 capture holds about 500 files, and the stamp check of every
    run lists them)."""
    out: dict[str, tuple[Path, os.stat_result]] = {}
    stack = [(str(root), "")]
    while stack:
        folder, prefix = stack.pop()
        with os.scandir(folder) as entries:
            for entry in entries:
                rel = prefix + entry.name
                if entry.is_dir():
                    stack.append((entry.path, rel + "/"))
                elif entry.is_file() and rel != ROOT_METADATA:
                    out[rel] = (Path(entry.path), entry.stat())
    return out


def _attrs_digest(attrs: dict[str, Any]) -> str:
    """sha256 of the capture attributes other than the stamp, canonical JSON."""
    rest = {k: v for k, v in attrs.items() if k != IDENTITY_ATTR}
    return hashlib.sha256(json.dumps(rest, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _content_hash(files: dict[str, tuple[int, str]], attrs_digest: str) -> str:
    h = hashlib.sha256(attrs_digest.encode())
    for rel in sorted(files):
        h.update(rel.encode())
        h.update(files[rel][1].encode())
    return h.hexdigest()


def stamp_capture(path: str | Path) -> str:
    """Hash every file of the capture store at ``path`` and write the identity stamp into its attributes.

    Returns the content hash. Call it once, after the last array is written (``write_capture`` does).
    """
    root_path = Path(path)
    group = zarr.open_group(str(root_path), mode="r+")
    files = {rel: (p.stat().st_size, hash_file(p)) for rel, p in _data_files(root_path).items()}
    attrs = dict(group.attrs)
    content_hash = _content_hash(files, _attrs_digest(attrs))
    # stamped after every file was written: a later modification time means a change in place
    group.attrs[IDENTITY_ATTR] = {
        "content_hash": content_hash,
        "files": {rel: [size, sha] for rel, (size, sha) in sorted(files.items())},
        "stamped_at_ns": time.time_ns(),
    }
    return content_hash


def capture_identity(path: str | Path, full: bool = False) -> CaptureIdentity:
    """The content identity of the capture at ``path``, checked against its stamp.

    Cheap by default: file names and sizes are compared with the stamp and only files modified after
    the stamp are read again; ``full=True`` reads every file. A capture without a stamp is hashed whole.

    Raises:
        CaptureChangedError: files were added, removed or changed since the stamp; the message names
            them and the fix.
    """
    root_path = Path(path)
    attrs = dict(zarr.open_group(str(root_path), mode="r").attrs)
    stamp = attrs.get(IDENTITY_ATTR)
    on_disk = _scan(root_path)
    if not stamp:
        return CaptureIdentity(hash_tree(root_path), "unstamped", len(on_disk) + 1)

    stamped: dict[str, tuple[int, str]] = {rel: (int(s), str(h)) for rel, (s, h) in stamp["files"].items()}
    stamped_at = int(stamp["stamped_at_ns"])
    problems: list[str] = []
    added = sorted(set(on_disk) - set(stamped))
    removed = sorted(set(stamped) - set(on_disk))
    if added:
        problems.append(f"files added: {', '.join(added[:5])}{' ...' if len(added) > 5 else ''}")
    if removed:
        problems.append(f"files removed: {', '.join(removed[:5])}{' ...' if len(removed) > 5 else ''}")
    rehashed = 0
    changed: list[str] = []
    for rel, (p, st) in sorted(on_disk.items()):
        if rel not in stamped:
            continue
        size, sha = stamped[rel]
        if st.st_size != size:
            changed.append(rel)
            continue
        if full or st.st_mtime_ns > stamped_at:
            rehashed += 1
            if hash_file(p) != sha:
                changed.append(rel)
    if changed:
        problems.append(f"files changed: {', '.join(changed[:5])}{' ...' if len(changed) > 5 else ''}")
    digest = _content_hash(stamped, _attrs_digest(attrs))
    if digest != stamp["content_hash"]:
        problems.append("attributes changed (scene id, instances or source)")
    if problems:
        raise CaptureChangedError(
            f"{root_path}: the capture changed since it was written ({'; '.join(problems)}). "
            "Write it again (rescene synth / rescene import), or restamp it if the change is intended "
            "(python -c 'from rescene_core.capture.identity import stamp_capture; stamp_capture(\"PATH\")')."
        )
    return CaptureIdentity(str(stamp["content_hash"]), "full" if full else "stamp", rehashed)
