"""Scene-level tasks: validation, room shell, key frames, per-frame relations, fusion, snapshot, attachment,
export, physics check, evaluation. Each runs one stage body of ``rescene_core.stages`` (which loads its
inputs from the run directory, calls its library and writes its output atomically) and returns its ``Ref``.
"""

from __future__ import annotations

# matplotlib.pyplot reads sys.modules["IPython"] when first imported and open3d imports IPython: two task
# threads importing them at once (the physics check's picture, the evaluation) fail on the half initialised
# module, so pyplot is imported here, once, before any task thread starts.
import matplotlib.pyplot  # noqa: F401

from rescene_core.config import AttachmentConfig, KeyFrameConfig, SceneGraphConfig, ShellConfig, SimcheckConfig
from rescene_core.export import ExportConfig
from rescene_core.records import Missing, Ref, Stage
from rescene_core.stages.dag import SPECS
from tasks.common import stage_task, vlm_slot


@stage_task(Stage.VALIDATE, retries=0)
def validate_capture(capture: Ref) -> Ref:
    """Validate the capture (raises CaptureError listing every problem); cached on its content hash."""
    return SPECS[Stage.VALIDATE].run(capture)


@stage_task(Stage.SHELL)
def estimate_shell(run_dir: str, capture: Ref, config: ShellConfig) -> Ref:
    """Room shell -> shell.json."""
    return SPECS[Stage.SHELL].run(run_dir, capture, config)


@stage_task(Stage.KEYFRAMES)
def select_keyframes(run_dir: str, capture: Ref, config: KeyFrameConfig) -> Ref:
    """Key frames by greedy 3D coverage -> keyframes.json; the reference lists the frames (``keyframes_of``)."""
    return SPECS[Stage.KEYFRAMES].run(run_dir, capture, config)


@stage_task(Stage.RELATIONS, tags=("gpu",))
def predict_relations(run_dir: str, capture: Ref, shell: Ref, frame: int, config: SceneGraphConfig) -> Ref:
    """Relation inference on one key frame -> scenegraph/frames/<t>.json and its ID overlay <t>.png; every
    VLM request holds a slot of the shared concurrency limit (``vlm_slot``)."""
    return SPECS[Stage.RELATIONS].run(run_dir, capture, shell, frame, config, request_slot=vlm_slot)


@stage_task(Stage.FUSION)
def fuse_graph(
    run_dir: str, capture: Ref, shell: Ref, predictions: list[Ref], missing: list[Missing], config: SceneGraphConfig
) -> Ref:
    """Multi-frame fusion of the per-frame predictions -> scenegraph/graph.json; ``missing``: the instances
    without a pose (fusion leaves them out)."""
    return SPECS[Stage.FUSION].run(run_dir, capture, shell, predictions, missing, config)


@stage_task(Stage.SNAPSHOT)
def snapshot_registration(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    assets: list[Ref],
    poses: list[Ref],
    wall_height: float,
    wall_thickness: float,
) -> Ref:
    """A foxglove.SceneUpdate of the registered scene (before attachment) on /scene/after_registration."""
    return SPECS[Stage.SNAPSHOT].run(run_dir, capture, shell, assets, poses, wall_height, wall_thickness)


@stage_task(Stage.ATTACHMENT)
def attach_layout(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    graph: Ref,
    assets: list[Ref],
    poses: list[Ref],
    config: AttachmentConfig,
    wall_height: float,
    wall_thickness: float,
) -> Ref:
    """Attachment along the scene graph -> layout.json, plus a SceneUpdate on /scene/after_attachment."""
    return SPECS[Stage.ATTACHMENT].run(
        run_dir, capture, shell, graph, assets, poses, config, wall_height, wall_thickness
    )


@stage_task(Stage.EXPORT)
def export(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    graph: Ref,
    layout: Ref,
    assets: list[Ref],
    poses: list[Ref],
    missing: list[Missing],
    config: ExportConfig,
) -> Ref:
    """scene/scene.glb, scene.usda, mjcf/scene.xml, scene.json and scene/objects/ from the layout."""
    return SPECS[Stage.EXPORT].run(run_dir, capture, shell, graph, layout, assets, poses, missing, config)


@stage_task(Stage.SIMCHECK)
def simcheck(run_dir: str, scene: Ref, config: SimcheckConfig) -> Ref:
    """The physics check of scene/mjcf/scene.xml -> sim/simcheck.json and sim/before_after.png."""
    return SPECS[Stage.SIMCHECK].run(run_dir, scene, config)


@stage_task(Stage.EVALUATION)
def evaluate(run_dir: str, capture: Ref, scene: Ref, keyframes: Ref | None = None, physics: Ref | None = None) -> Ref:
    """Every metric the run allows -> eval/metrics.json, report.md, report.html."""
    return SPECS[Stage.EVALUATION].run(run_dir, capture, scene, keyframes, physics)
