"""The one place where the stage bodies call the stage libraries.

Each function here forwards to one ``rescene_core`` stage function. The import happens at call time,
so a stage whose library module is not part of this build raises ``StageNotAvailable`` naming the
module, instead of the pipeline silently skipping or faking it. Tests substitute these functions
(monkeypatching this module) to exercise caching, retries and fan-out on their own.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rescene_core.records import (
    Asset,
    InstanceId,
    InstancePoints,
    Layout,
    Missing,
    Pose,
    RoomShell,
    SceneGraph,
    Stage,
    ViewChoice,
)

if TYPE_CHECKING:  # the stage packages are imported when a stage runs, not when the harness loads
    from rescene_core.assembly import AssemblyObject
    from rescene_core.capture import Capture
    from rescene_core.config import (
        AssetConfig,
        AttachmentConfig,
        HierViewConfig,
        KeyFrameConfig,
        RegistrationConfig,
        SceneGraphConfig,
        ShellConfig,
    )
    from rescene_core.hierview import KeyFrames
    from rescene_core.scenegraph import FramePrediction, FusionReport, RelationPredictor


class StageNotAvailable(RuntimeError):
    """A stage's library module is not part of this build; the message names the module."""

    def __init__(self, stage: Stage, module: str, cause: BaseException | None = None):
        self.stage = stage
        self.module = module
        detail = f" ({cause})" if cause else ""
        super().__init__(f"stage {stage!r} is not available: its library module {module!r} cannot be imported{detail}")


def _load(stage: Stage, module: str, name: str) -> Any:
    """``module.name``, imported now; StageNotAvailable when the module (not one of its imports) is absent."""
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name and (module == err.name or module.startswith(err.name + ".")):
            raise StageNotAvailable(stage, module, err) from err
        raise
    if not hasattr(mod, name):
        raise StageNotAvailable(stage, f"{module}.{name}")
    return getattr(mod, name)


# ---- the stage calls: one library function each -------------------------------------------------


def estimate_shell(capture: Capture, config: ShellConfig) -> RoomShell:
    """rescene_core.shell.estimate_shell(capture, ShellConfig) -> RoomShell."""
    return _load(Stage.SHELL, "rescene_core.shell", "estimate_shell")(capture, config)


def select_views(capture: Capture, config: HierViewConfig, instance_ids: list[int]) -> dict[int, ViewChoice | Missing]:
    """rescene_core.hierview.select_views(...) -> {instance id: ViewChoice | Missing}."""
    return _load(Stage.VIEW, "rescene_core.hierview", "select_views")(capture, config, instance_ids=instance_ids)


def select_keyframes(capture: Capture, config: KeyFrameConfig) -> KeyFrames:
    """rescene_core.hierview.select_keyframes(capture, KeyFrameConfig) -> KeyFrames (frames, to_json())."""
    return _load(Stage.KEYFRAMES, "rescene_core.hierview", "select_keyframes")(capture, config)


def generate_asset(capture: Capture, view: ViewChoice, config: AssetConfig) -> Asset | Missing:
    """rescene_core.assets.generate_asset(capture, ViewChoice, AssetConfig) -> Asset | Missing."""
    return _load(Stage.ASSET, "rescene_core.assets", "generate_asset")(capture, view, config)


def save_asset(path: Path, asset: Asset) -> None:
    """rescene_core.assets.save_asset(path.glb, Asset)."""
    _load(Stage.ASSET, "rescene_core.assets", "save_asset")(path, asset)


def load_asset(path: Path, instance: InstanceId) -> Asset:
    """rescene_core.assets.load_asset(path.glb, instance) -> Asset."""
    return _load(Stage.ASSET, "rescene_core.assets", "load_asset")(path, instance)


def register(asset: Asset, target: InstancePoints, config: RegistrationConfig) -> Pose | Missing:
    """rescene_core.registration.register(Asset, InstancePoints, RegistrationConfig) -> Pose | Missing."""
    return _load(Stage.REGISTRATION, "rescene_core.registration", "register")(asset, target, config)


def make_predictor(config: SceneGraphConfig) -> RelationPredictor:
    """rescene_core.scenegraph.make_predictor(SceneGraphConfig) -> relation predictor."""
    return _load(Stage.RELATIONS, "rescene_core.scenegraph", "make_predictor")(config)


def predict_frame(
    capture: Capture, frame: int, shell: RoomShell, config: SceneGraphConfig, predictor: RelationPredictor
) -> FramePrediction:
    """rescene_core.scenegraph.predict_frame(...) -> FramePrediction (to_json())."""
    return _load(Stage.RELATIONS, "rescene_core.scenegraph", "predict_frame")(capture, frame, shell, config, predictor)


def frame_prediction_from_json(data: dict[str, Any]) -> FramePrediction:
    """rescene_core.scenegraph.FramePrediction.from_json(dict) -> FramePrediction."""
    return _load(Stage.FUSION, "rescene_core.scenegraph", "FramePrediction").from_json(data)


def fuse(
    predictions: list[FramePrediction], capture: Capture, shell: RoomShell, config: SceneGraphConfig, missing: set[int]
) -> SceneGraph:
    """rescene_core.scenegraph.fuse(predictions, capture, shell, SceneGraphConfig, missing ids) -> SceneGraph."""
    return _load(Stage.FUSION, "rescene_core.scenegraph", "fuse")(predictions, capture, shell, config, missing)


def fuse_with_report(
    predictions: list[FramePrediction],
    capture: Capture,
    shell: RoomShell,
    config: SceneGraphConfig,
    missing: set[int],
    predictor: RelationPredictor,
) -> tuple[SceneGraph, FusionReport | None]:
    """rescene_core.scenegraph.fuse_with_report(...) -> (SceneGraph, FusionReport); uncertain edges are
    re-asked with the A/B prompt through ``predictor`` when its backend supports it."""
    return _load(Stage.FUSION, "rescene_core.scenegraph", "fuse_with_report")(
        predictions, capture, shell, config, missing, predictor
    )


def write_frame(out_dir: Path, capture: Capture, prediction: FramePrediction, config: SceneGraphConfig) -> Any:
    """rescene_core.scenegraph.write_frame: frames/<t>.json (the prediction) and frames/<t>.png (ID overlay)."""
    return _load(Stage.RELATIONS, "rescene_core.scenegraph", "write_frame")(out_dir, capture, prediction, config)


def write_graph(
    out_dir: Path, graph: SceneGraph, capture: Capture, shell: RoomShell, report: FusionReport | None
) -> Any:
    """rescene_core.scenegraph.write_graph: graph.json (edges, labels, report) and graph.png (over the plan)."""
    return _load(Stage.FUSION, "rescene_core.scenegraph", "write_graph")(out_dir, graph, capture, shell, report)


def assembly_object(
    instance: int,
    label: str,
    vertices: np.ndarray,
    faces: np.ndarray,
    world_from_asset: np.ndarray,
    points: np.ndarray | None = None,
) -> AssemblyObject:
    """rescene_core.assembly.AssemblyObject for one registered instance; points: the world points
    float64 [n, 3] the capture saw of it (the solver's evidence for support planes and bounded moves)."""
    cls = _load(Stage.ATTACHMENT, "rescene_core.assembly", "AssemblyObject")
    return cls(
        instance=InstanceId(int(instance)),
        label=label,
        vertices=vertices,
        faces=faces,
        world_from_asset=world_from_asset,
        points=points,
    )


def attach(
    objects: dict[InstanceId, AssemblyObject], graph: SceneGraph, shell: RoomShell, config: AttachmentConfig
) -> Layout:
    """rescene_core.assembly.attach(objects, SceneGraph, RoomShell, AttachmentConfig) -> Layout."""
    return _load(Stage.ATTACHMENT, "rescene_core.assembly", "attach")(objects, graph, shell, config)
