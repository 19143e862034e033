"""Which device each stage's models ran on, for the run log.

A model is built once per process (CLIP, SAM 3D's pipeline, the segment labeller) and used by many stage
executions; each use says where it runs with ``note_device(component, device)``. ``executing`` (the
context of one stage execution, ``rescene_core.stages.execution``) collects what was noted inside it with
``recording_devices`` and writes it into the stage's end event on ``/task/events`` as ``devices``
(component -> ``"cuda:0"``, ``"cpu"``...), which ``rescene log`` lists per stage. A stage whose
libraries use no torch model records none: it ran on the CPU. Per execution through a context variable,
so the tasks of one process's thread pool do not mix their notes.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

_CURRENT: ContextVar[dict[str, str] | None] = ContextVar("rescene_stage_devices", default=None)


def note_device(component: str, device: object) -> None:
    """Record that ``component`` (e.g. ``"clip"``) runs on ``device`` (a ``torch.device`` or its name) in
    the stage execution under way; nothing outside one."""
    current = _CURRENT.get()
    if current is not None:
        current[component] = str(device)


@contextmanager
def recording_devices() -> Iterator[dict[str, str]]:
    """Collect the ``note_device`` calls made inside the block: yields the dict they fill."""
    devices: dict[str, str] = {}
    token = _CURRENT.set(devices)
    try:
        yield devices
    finally:
        _CURRENT.reset(token)


def module_device(module: object) -> str:
    """The device of a torch module's first parameter (``"cpu"`` for a module without parameters)."""
    parameters = getattr(module, "parameters", None)
    first = next(iter(parameters()), None) if callable(parameters) else None
    return str(first.device) if first is not None else "cpu"
