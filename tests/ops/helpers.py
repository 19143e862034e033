"""Helpers for the fault drills: a small tmpfs to fill, and the consistency check of a run directory's
cache records against the files they stand for."""

from __future__ import annotations

import subprocess
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from prefect.results import ResultRecord

from rescene_core.io import hash_file, hash_tree
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage

STAGES = {str(s) for s in Stage}


@contextmanager
def small_tmpfs(path: Path, size_kib: int) -> Iterator[Path]:
    """Mount a tmpfs of ``size_kib`` KiB at ``path`` (created) for the block; skips the test with the reason
    when mounting is not allowed here (not root, or a container without CAP_SYS_ADMIN)."""
    path.mkdir(parents=True, exist_ok=True)
    out = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size_kib}k,mode=0755", "tmpfs", str(path)],
        capture_output=True, text=True,
    )  # fmt: skip
    if out.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs to fill (needs root or CAP_SYS_ADMIN): {out.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


def resize_tmpfs(path: Path, size_kib: int) -> None:
    """Grow (or shrink) the tmpfs mounted at ``path`` to ``size_kib`` KiB: the space an operator frees."""
    subprocess.run(["mount", "-o", f"remount,size={size_kib}k", str(path)], check=True)


def trusted_records(run_dir: Path) -> tuple[Counter, list[str]]:
    """The stage cache records of ``run_dir`` that a later run would serve (they parse as a result record),
    counted per stage, and the problems found: a record that parses but whose reference's file is missing
    or differs from the sha256 it records (a record a later run would trust wrongly).

    Records that do not parse (cut short by a full disk or a kill) are not counted: Prefect treats them as
    absent (``ResultStore.exists`` deserialises the record) and runs the task again."""
    trusted: Counter = Counter()
    problems: list[str] = []
    for record in sorted(RunPaths(run_dir).results.iterdir()):
        stage = record.name.rsplit("-", 1)[0]
        if stage not in STAGES:
            continue  # a flow or failed-state result, not a cache record of a stage
        try:
            result = ResultRecord.deserialize(record.read_bytes()).result
        except Exception:  # noqa: BLE001 - what ResultStore.exists catches: the record counts as absent
            continue
        trusted[stage] += 1
        for ref in result if isinstance(result, list) else [result]:
            if not isinstance(ref, Ref) or ref.kind == "capture":
                continue
            # the export's reference stands for every file under scene/, each hash in its detail
            files = {f"scene/{k}": v for k, v in ref.detail["files"].items()} if ref.kind == "scene" else {}
            for path, sha in (files or {ref.path: ref.sha256}).items():
                target = run_dir / path
                if not target.exists():
                    problems.append(f"{record.name}: {path} missing")
                elif (hash_tree(target) if target.is_dir() else hash_file(target)) != sha:
                    problems.append(f"{record.name}: {path} differs from the recorded sha256")
    return trusted, problems


def leftover_temporaries(run_dir: Path) -> list[str]:
    """Temporary files of the atomic writes (``.<name>.<random>``) left under ``run_dir``, outside the
    cache records of Prefect and the run lock."""
    out = []
    for p in run_dir.rglob(".*"):
        rel = p.relative_to(run_dir)
        if rel.parts[0] in (".prefect", ".lock", ".faults"):
            continue
        out.append(str(rel))
    return out
