"""What every ReScene task shares: the input-hash cache policy, retries and the shared VLM limit.

A task runs one stage body (``rescene_core.stages``) and returns its ``Ref``. The cache key of a task run
is built from ``Ref.cache_digest()`` of its input references, the hash of its config section and the code
version of its stage (``rescene_core.stages.dag.code_version``: the import closure of the stage), so a
changed input recomputes exactly what depends on it. Results are persisted as JSON (Prefect's JSON
serializer writes the Ref's fields and its class name; no pickles) under ``RUN/.prefect/results``.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
from prefect import Task, task
from prefect.cache_policies import CachePolicy
from prefect.context import TaskRunContext
from pydantic import BaseModel

from rescene_core import paths
from rescene_core.records import Missing, Ref, Stage
from rescene_core.stages.dag import StageSpec, code_version
from rescene_core.stages.execution import BadInputError, TransientStageError

RESULTS_DIR = Path(paths.RESULTS)
"""Persisted task results (JSON references) and cache records, relative to the run directory."""

RETRIES = 3
"""Retries of a task after a transient failure (a VLM timeout, a dropped connection)."""

RETRY_DELAY_ENV = "RESCENE_RETRY_DELAY_S"
"""Environment variable: base delay of the exponential retry backoff in seconds (default 2)."""


# ---- retries -------------------------------------------------------------------------------------


def is_transient(exc: BaseException) -> bool:
    """Timeouts and connection errors are transient; everything else (bad input, bugs) is not."""
    flag = getattr(exc, "transient", None)
    if flag is not None:
        return bool(flag)
    if isinstance(exc, TimeoutError | ConnectionError):
        return True
    if isinstance(exc, httpx.TimeoutException | httpx.TransportError):
        return True
    return isinstance(exc, httpx.HTTPStatusError) and exc.response.status_code >= 500


def retry_transient(task_, task_run, state) -> bool:
    """Prefect ``retry_condition_fn``: retry only when the task failed with a transient error."""
    try:
        state.result()
    except BaseException as exc:  # noqa: BLE001 - the state carries whatever the task raised
        return is_transient(exc)
    return False


def retry_delays(retries: int = RETRIES) -> list[float]:
    """Exponential backoff: base, 2 x base, 4 x base ... seconds (base from RESCENE_RETRY_DELAY_S)."""
    base = float(os.environ.get(RETRY_DELAY_ENV, "2"))
    return [base * 2**k for k in range(retries)]


# ---- references and cache keys -------------------------------------------------------------------


def digest(value: Any) -> Any:
    """What of a task input goes into its cache key: content hashes of references, the hash of config
    sections, and plain values as they are."""
    if isinstance(value, Ref):
        return value.cache_digest()
    if isinstance(value, Missing):
        return value.to_json()
    if isinstance(value, BaseModel):
        blob = json.dumps(value.model_dump(mode="json"), sort_keys=True)
        return {"config": type(value).__name__, "sha256": hashlib.sha256(blob.encode()).hexdigest()[:16]}
    if isinstance(value, dict):
        return {str(k): digest(v) for k, v in sorted(value.items())}
    if isinstance(value, list | tuple):
        return [digest(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if value is None or isinstance(value, str | int | float | bool):
        return value
    raise TypeError(f"task input of type {type(value).__name__} cannot be part of a cache key; pass a reference")


UNKEYED_INPUTS = frozenset({"run_dir", "request_slot", "wall_height", "wall_thickness"})
"""Task inputs that say where a run lives, how it reaches a shared service or how its run log draws the
walls, not what it computes: left out of cache keys, so a run directory that moved (or is mounted
elsewhere) keeps its cache, and a wall box's size re-runs the export, not attachment."""


@dataclass
class StageInputs(CachePolicy):
    """Cache key = stage name + code version of the stage + digest of the inputs (see ``digest``),
    the run directory's location (``UNKEYED_INPUTS``) excluded."""

    stage: Stage = Stage.VALIDATE

    def compute_key(
        self, task_ctx: TaskRunContext, inputs: dict[str, Any], flow_parameters: dict[str, Any], **kwargs: Any
    ) -> str | None:
        blob = json.dumps(
            {
                "stage": self.stage,
                "code": code_version(self.stage),
                "inputs": digest({k: v for k, v in inputs.items() if k not in UNKEYED_INPUTS}),
            },
            sort_keys=True,
        )
        key = f"{self.stage}-{hashlib.sha256(blob.encode()).hexdigest()[:32]}"
        if "run_dir" in inputs:
            drop_record_of_lost_output(Path(inputs["run_dir"]), key)
        return key


REF_CLASS = f"{Ref.__module__}.{Ref.__qualname__}"


def _ref_paths(value: Any) -> Iterator[str]:
    """The ``path`` of every serialised Ref in a decoded task result (a Ref, or lists and dicts of them)."""
    if isinstance(value, dict):
        if value.get("__class__") == REF_CLASS and isinstance(value.get("data"), dict):
            yield str(value["data"].get("path", ""))
        else:
            for v in value.values():
                yield from _ref_paths(v)
    elif isinstance(value, list):
        for v in value:
            yield from _ref_paths(v)


def drop_record_of_lost_output(run_dir: Path, key: str) -> Path | None:
    """Remove the cache record ``key`` of ``run_dir`` when a file its result refers to no longer exists (an
    output deleted by hand, or a run directory copied without it), so the task runs again instead of
    returning a reference to nothing; returns the lost file, None when the record is sound or absent. A
    record that cannot be read is left to Prefect, which runs the task when it cannot load it."""
    record = run_dir / RESULTS_DIR / key
    try:
        result = json.loads(json.loads(record.read_text())["result"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    for rel in _ref_paths(result):
        target = run_dir / rel
        if rel and not target.exists():
            record.unlink(missing_ok=True)
            return target
    return None


def task_of(spec: StageSpec) -> Task[..., Any]:
    """The Prefect task of a declared stage: its body with the input-hash cache policy, JSON results,
    retries with backoff on transient errors only (none where the stage is not retried), tagged ``gpu``
    where its backend wants one."""
    retries = RETRIES if spec.retried else 0
    return stage_task(spec.stage, retries, ("gpu",) if spec.gpu else ())(spec.run)


def stage_task(stage: Stage, retries: int = RETRIES, tags: tuple[str, ...] = ()):
    """Decorator: a Prefect task of ``stage`` with the input-hash cache policy, JSON results, and
    retries with backoff on transient errors only."""
    return task(
        name=stage,
        cache_policy=StageInputs(stage=stage),
        persist_result=True,
        result_serializer="json",
        retries=retries,
        retry_delay_seconds=retry_delays(retries),
        retry_jitter_factor=0.2,
        retry_condition_fn=retry_transient,
        tags=set(tags),
    )


# ---- shared VLM endpoint: a Prefect global concurrency limit ---------------------------------------

VLM_LIMIT_ENV = "RESCENE_VLM_LIMIT"
"""Environment variable (set on the GPU pool's workers): the name of the Prefect global concurrency limit
that every VLM request of the relation stage holds a slot of, shared by all workers and flow runs
(create it with ``prefect gcl create NAME --limit N``, one per endpoint). Unset: no shared limit."""


class ConcurrencyLimitMissingError(BadInputError):
    """RESCENE_VLM_LIMIT names a global concurrency limit that the Prefect server does not have."""


@contextmanager
def vlm_slot(base_url: str) -> Iterator[None]:
    """Hold one slot of the global concurrency limit named by RESCENE_VLM_LIMIT around a VLM request
    (nothing when unset). A name that does not exist on the server is a clear, non-retried error."""
    name = os.environ.get(VLM_LIMIT_ENV, "").strip()
    if not name:
        yield
        return
    from prefect.concurrency._asyncio import ConcurrencySlotAcquisitionError
    from prefect.concurrency.sync import concurrency

    try:
        ctx = concurrency(name, occupy=1, strict=True)
        ctx.__enter__()
    except ConcurrencySlotAcquisitionError as err:
        if "must be created" not in str(err):  # the server did not answer: retried with backoff
            raise TransientStageError(f"{VLM_LIMIT_ENV}={name!r}: {err}") from err
        raise ConcurrencyLimitMissingError(
            f"{VLM_LIMIT_ENV}={name!r} (VLM endpoint {base_url}): no global concurrency limit of that name on "
            f"the Prefect server; create it with `prefect gcl create {name} --limit N` or unset {VLM_LIMIT_ENV} "
            f"({err})"
        ) from err
    try:
        yield
    except BaseException as exc:
        if not ctx.__exit__(type(exc), exc, exc.__traceback__):
            raise
    else:
        ctx.__exit__(None, None, None)
