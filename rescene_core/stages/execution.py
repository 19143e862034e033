"""What every stage body shares when it runs: the reference it returns, its run-log segment, the errors
that say whether a retry can help, and fault injection for the drills.

A stage body's result is a ``rescene_core.records.Ref``: a frozen record naming the file it wrote under
the run directory, that file's sha256, its status (OK or MISSING) and a few numbers. Prefect is not
needed here: the tasks (tasks/) and the in-process pipeline (rescene_core/pipeline.py) run the same bodies.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rescene_core import paths
from rescene_core.capture import open_capture
from rescene_core.capture.identity import CaptureChangedError, capture_identity
from rescene_core.io import hash_file, write_json_atomic
from rescene_core.ops.devices import recording_devices
from rescene_core.paths import RunPaths
from rescene_core.records import Missing, Ref, RefStatus, Stage
from rescene_core.runlog import Segment

# ---- errors --------------------------------------------------------------------------------------


class TransientStageError(RuntimeError):
    """A failure that may pass on its own (timeout, connection reset): retried with backoff."""

    transient = True


class BadInputError(ValueError):
    """A failure caused by the input itself: retrying cannot help, so it is not retried."""

    transient = False


# ---- references: what a stage returns, the capture it reads ----------------------------------------------------------------------------------


def make_ref(
    run_dir: str | Path,
    path: str | Path,
    kind: str,
    item: int | None = None,
    numbers: dict[str, Any] | None = None,
    missing: Missing | None = None,
    detail: dict[str, Any] | None = None,
) -> Ref:
    """Reference to the file ``path`` (absolute, or relative to ``run_dir``) that a stage wrote: its
    run-relative path, sha256, status (MISSING when ``missing`` is given) and a few numbers."""
    run = RunPaths(run_dir)
    full = Path(path) if Path(path).is_absolute() else run.root / path
    return Ref(
        kind=kind,
        path=run.rel(full),
        sha256=hash_file(full),
        item=None if item is None else int(item),
        status=RefStatus.OK if missing is None else RefStatus.MISSING,
        numbers=numbers or {},
        missing=missing,
        detail=detail or {},
    )


def passthrough(run_dir: str | Path, path: Path, kind: str, instance: int, missing: Missing) -> Ref:
    """The reference of an instance a stage does not handle: its file records the Missing, status MISSING."""
    write_json_atomic(path, {"instance": instance, "status": "missing", "missing": missing.to_json()})
    return make_ref(run_dir, path, kind, instance, missing=missing)


VERIFY_CAPTURE = ("stamp", "full")
"""How a run establishes the capture's content hash: "stamp" (default: the identity stamped into the
capture when it was written, checked by file sizes and by rehashing only files modified since) or
"full" (every byte rehashed against the stamp). An unstamped capture is hashed whole either way."""


def capture_ref(capture: str | Path, verify: str = "stamp") -> Ref:
    """Reference to the capture (outside the run directory): absolute path and its content hash.

    The hash is the capture's identity stamp (``rescene_core.capture.identity``), verified as ``verify``
    says; ``detail`` records how (``verification``, ``rehashed_files``). Raises CaptureChangedError when
    the capture changed in place since it was written."""
    if verify not in VERIFY_CAPTURE:
        raise ValueError(f"verify_capture={verify!r}: use one of {', '.join(VERIFY_CAPTURE)}")
    path = Path(capture).resolve()
    try:
        ident = capture_identity(path, full=verify == "full")
    except CaptureChangedError:
        open_capture(path)  # changed and also invalid: the list of its problems is the clearer error
        raise
    detail = {"verification": ident.verification, "rehashed_files": ident.rehashed_files}
    return Ref(kind="capture", path=str(path), sha256=ident.content_hash, detail=detail)


# ---- execution: run-log segment, fault injection -------------------------------------------------


def segment_name(stage: Stage, item: int | None) -> str:
    """The run-log segment of one stage execution: the stage, and the instance or frame it ran on."""
    return stage if item is None else f"{stage}-{int(item):06d}"


@contextmanager
def executing(run_dir: str | Path, stage: Stage, item: int | None = None) -> Iterator[Segment]:
    """Context of one stage execution: yields its run-log segment (replacing any earlier one), logs
    start/end/error events with the elapsed seconds (the end event with the devices its models ran on),
    applies injected faults, writes the segment."""
    seg = Segment(Path(run_dir), segment_name(stage, item))
    start = time.perf_counter()
    pid = os.getpid()
    seg.log(
        "/task/events",
        {"stage": stage, "item": item, "event": "start", "seconds": 0.0, "status": "running", "pid": pid},
    )
    try:
        with recording_devices() as devices:  # where the stage's models ran (rescene_core/ops/devices.py)
            inject_fault(run_dir, stage, item)
            yield seg
    except BaseException as exc:
        seg.log(
            "/task/events",
            {
                "stage": stage,
                "item": item,
                "event": "error",
                "seconds": time.perf_counter() - start,
                "status": "failed",
                "error": f"{type(exc).__name__}: {exc}",
            },
        )
        seg.close()
        raise
    seg.log(
        "/task/events",
        {
            "stage": stage,
            "item": item,
            "event": "end",
            "seconds": time.perf_counter() - start,
            "status": "ok",
            "pid": pid,
            "devices": devices,
        },
    )
    seg.close()


FAULTS_FILE = paths.FAULTS
"""Fault injection for tests and drills: ``RUN/faults.json`` = [{"stage", "item", "kind", "times"}].

kind "transient" raises TransientStageError (retried), "bad_input" raises BadInputError (not retried);
each fault fires ``times`` times in all (counted in RUN/.faults/), then clears."""


def inject_fault(run_dir: str | Path, stage: Stage, item: int | None) -> None:
    """Raise the fault ``RUN/faults.json`` asks for at this stage and item, if it has not fired out."""
    run = RunPaths(run_dir)
    path = run.faults
    if not path.exists():
        return
    for fault in json.loads(path.read_text()):
        if fault.get("stage") != stage or fault.get("item") != item:
            continue
        counter = run.fault_count(segment_name(stage, item))
        fired = int(counter.read_text()) if counter.exists() else 0
        if fired >= int(fault.get("times", 1)):
            continue
        write_json_atomic(counter, fired + 1)
        kind = fault.get("kind", "transient")
        message = f"injected {kind} fault in {stage} for item {item} ({fired + 1}/{fault.get('times', 1)})"
        raise TransientStageError(message) if kind == "transient" else BadInputError(message)
