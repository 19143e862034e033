"""The stage description: every stage declared once, and the one DAG list both drivers run.

A ``StageSpec`` says what a stage is: its ``Stage`` name, its body (a function of the run directory,
references and one config section that writes its output under the run directory and returns a ``Ref``),
the library package(s) the body calls, the ``RunConfig`` section it reads, what it fans out over and the
name its result goes by. The body's parameter names are its inputs: the names of earlier stages' results
(``shell``, ``graph``...), of the fan-in values (``assets``, ``poses``, ``missing``), of the item a fanned-out
stage runs on (``view``, ``asset``, ``frame``) and of a few run values (``run_dir``, ``capture``,
``instances``, the walls' drawing size).

``DAG`` is the order of the stages. ``rescene_core.pipeline`` runs it in this process; the Prefect flow
(flows/scene.py) wraps each body in a task (tasks/) and wires the same list with fan-out, retries and
Missing instances. A stage's cache key is made of its code version (``code_version``: the import closure of
its body and library) and the digest of exactly its inputs, its config section among them.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

from rescene_core.config import RunConfig
from rescene_core.records import Layout, Pose, RoomShell, SceneGraph, Stage, ViewChoice
from rescene_core.stages import (
    asset,
    attachment,
    evaluation,
    export,
    fusion,
    keyframes,
    registration,
    relations,
    shell,
    simcheck,
    snapshot,
    validate,
    view,
)
from rescene_core.stages.version import source_hash

RUN_INPUTS = frozenset({"run_dir", "capture", "instances", "config", "wall_height", "wall_thickness"})
"""Body parameters that no stage produces: where the run lives, the capture's reference and object ids,
the stage's config section, the walls' drawing size (from the export section). A body may also take
parameters with defaults that the harness sets (relations' ``request_slot``)."""

FAN_IN_INPUTS = frozenset({"missing", "frames"})
"""Values gathered between stages: every Missing instance (after registration), the key frames (from
the key-frame reference)."""


@dataclass(frozen=True)
class StageSpec:
    """One stage, declared once. ``record``: the record type of the file the stage writes (None where the
    output is a set of files: the exports, the physics check, the metrics)."""

    stage: Stage
    run: Callable[..., Any]
    """The stage body (``rescene_core/stages/<stage>.py:run``)."""
    output: str
    """The name later stages' parameters use for this stage's result."""
    library: tuple[str, ...] = ()
    """Library packages the body calls through ``calls`` (loaded when the stage runs, so they are named here
    for the code version)."""
    config: str | None = None
    """The RunConfig section passed as the body's ``config`` parameter."""
    over: tuple[str, str] | None = None
    """For a stage that runs once per instance or key frame: (the list it runs over, the body parameter
    that takes one item of it): ``("views", "view")`` runs the body once per view reference."""
    record: type | None = None
    writes: str = ""
    """The run-directory files it writes (docs/run-directory.md)."""
    when: Callable[[RunConfig], bool] | None = None
    """Runs only when this says so for the run's config (None: always)."""
    gpu: bool = False
    """Calls a model backend that wants a GPU worker (its Prefect tasks are tagged ``gpu``)."""
    gpu_when: Callable[[RunConfig], bool] | None = None
    """For a ``gpu`` stage, whether the run's configured backend is one (None: always). A weight-free CPU
    backend needs no GPU worker, and an untagged task asks the API for no concurrency slot."""
    retried: bool = True
    """Retried after a transient failure (validation is not: a capture that fails it stays failed)."""

    @property
    def inputs(self) -> tuple[str, ...]:
        """The body's parameter names, in order."""
        return tuple(inspect.signature(self.run).parameters)

    def enabled(self, config: RunConfig) -> bool:
        return self.when is None or self.when(config)

    def wants_gpu(self, config: RunConfig) -> bool:
        """Whether this run's tasks of the stage carry the ``gpu`` tag."""
        return self.gpu and (self.gpu_when is None or self.gpu_when(config))

    def config_section(self, config: RunConfig) -> Any:
        """The section of ``config`` this stage reads (None when it reads none)."""
        return None if self.config is None else getattr(config, self.config)


def _simulate(config: RunConfig) -> bool:
    return config.export.simulation


def _asset_model(config: RunConfig) -> bool:
    """SAM 3D Objects wants a GPU; ``lift`` is a weight-free CPU backend."""
    return config.assets.backend != "lift"


def _relation_model(config: RunConfig) -> bool:
    """A VLM endpoint is a GPU service; the ``geometric`` predictor is weight-free, on the CPU."""
    return config.scenegraph.backend != "geometric"


DAG: tuple[StageSpec, ...] = (
    StageSpec(Stage.VALIDATE, validate.run, "validated", ("rescene_core.capture",), writes="(checks the capture)",
              retried=False),
    StageSpec(Stage.SHELL, shell.run, "shell", ("rescene_core.shell",), "shell", record=RoomShell, writes="shell.json"),
    StageSpec(Stage.VIEW, view.run, "views", ("rescene_core.hierview",), "hierview", record=ViewChoice,
              writes="instances/<id>/view.json"),
    StageSpec(Stage.ASSET, asset.run, "assets", ("rescene_core.assets",), "assets", over=("views", "view"),
              writes="instances/<id>/asset.glb, asset.json", gpu=True, gpu_when=_asset_model),
    StageSpec(Stage.REGISTRATION, registration.run, "poses", ("rescene_core.registration", "rescene_core.assets"),
              "registration", over=("assets", "asset"), record=Pose, writes="instances/<id>/pose.json"),
    StageSpec(Stage.KEYFRAMES, keyframes.run, "keyframes", ("rescene_core.hierview",), "keyframes",
              writes="keyframes.json"),
    StageSpec(Stage.RELATIONS, relations.run, "predictions", ("rescene_core.scenegraph",), "scenegraph",
              over=("frames", "frame"), writes="scenegraph/frames/<t>.json, <t>.png", gpu=True,
              gpu_when=_relation_model),
    StageSpec(Stage.FUSION, fusion.run, "graph", ("rescene_core.scenegraph",), "scenegraph", record=SceneGraph,
              writes="scenegraph/graph.json, graph.png"),
    StageSpec(Stage.SNAPSHOT, snapshot.run, "snapshot", writes="after_registration.json"),
    StageSpec(Stage.ATTACHMENT, attachment.run, "layout", ("rescene_core.assembly",), "attachment", record=Layout,
              writes="layout.json"),
    StageSpec(Stage.EXPORT, export.run, "scene", config="export", writes="scene/"),
    StageSpec(Stage.SIMCHECK, simcheck.run, "physics", config="sim", writes="sim/", when=_simulate),
    StageSpec(Stage.EVALUATION, evaluation.run, "metrics", writes="eval/"),
)  # fmt: skip
"""The stages in the order they run in this process (the flow runs independent ones side by side)."""

SPECS: dict[Stage, StageSpec] = {s.stage: s for s in DAG}


def roots(stage: Stage) -> tuple[str, ...]:
    """The modules a stage's code version starts its import closure from: its body and its library packages."""
    spec = SPECS[Stage(stage)]
    return (spec.run.__module__, *spec.library)


def code_version(stage: Stage | str) -> str:
    """Hash of the import closure of the stage's body and library packages (``version.source_hash``),
    computed once per process and stage (``Stage.VIEW`` and ``"view"`` are one entry)."""
    return _code_version(Stage(stage))


@cache
def _code_version(stage: Stage) -> str:
    return source_hash(roots(stage))


def code_versions() -> dict[Stage, str]:
    """The code version of every stage (the manifest records them)."""
    return {s.stage: code_version(s.stage) for s in DAG}


def check_dag(dag: tuple[StageSpec, ...] = DAG) -> None:
    """Raise when a body parameter is neither a run input, a gathered value, its item nor an earlier result."""
    produced: set[str] = set()
    for spec in dag:
        known = RUN_INPUTS | FAN_IN_INPUTS | produced | ({spec.over[1]} if spec.over else set())
        unknown = [p for p in spec.inputs if p not in known and inspect.signature(spec.run).parameters[p].default
                   is inspect.Parameter.empty]  # fmt: skip
        if unknown or (spec.over and spec.over[0] not in produced | FAN_IN_INPUTS):
            raise ValueError(f"stage {spec.stage}: inputs {unknown or spec.over} come from no earlier stage")
        produced.add(spec.output)
