"""Scene-level tasks: room shell, key frames, per-frame relations, fusion, attachment, export, evaluation.

Each loads its inputs from the run directory, calls one library function, writes its output atomically
and returns a ``Ref`` (see tasks/common.py). Paths come from ``RunPaths``.
"""

from __future__ import annotations

import dataclasses
from contextlib import nullcontext
from pathlib import Path

# matplotlib.pyplot reads sys.modules["IPython"] when first imported and open3d imports IPython: two task
# threads importing them at once (the physics check's picture, the evaluation) fail on the half initialised
# module, so pyplot is imported here, once, before any task thread starts.
import matplotlib.pyplot  # noqa: F401
import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import AttachmentConfig, KeyFrameConfig, SceneGraphConfig, ShellConfig, SimcheckConfig
from rescene_core.evaluation import evaluate_run
from rescene_core.export import ExportConfig, export_scene, placed_objects
from rescene_core.io import read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Layout, Missing, Pose, Ref, RoomShell, SceneGraph, Stage
from rescene_core.runlog import SceneObject, now_ns, scene_update
from tasks import stages
from tasks.common import TransientStageError, executing, make_ref, stage_task, vlm_slot
from tasks.instance import load_asset_ref


@stage_task(Stage.VALIDATE, retries=0)
def validate_capture(capture: Ref) -> Ref:
    """Validate the capture (raises CaptureError listing every problem); cached on its content hash."""
    cap = open_capture(capture.path, validate=True)
    return dataclasses.replace(capture, numbers={"frames": cap.num_frames, "instances": len(cap.instances)})


def load_shell(run_dir: str, ref: Ref) -> RoomShell:
    return RoomShell.from_json(read_json(Path(run_dir) / ref.path))


def keyframes_of(ref: Ref) -> list[int]:
    """The key frames listed by a ``select_keyframes`` reference."""
    return [int(t) for t in ref.detail["frames"]]


@stage_task(Stage.SHELL)
def estimate_shell(run_dir: str, capture: Ref, config: ShellConfig) -> Ref:
    """Room shell -> shell.json."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SHELL) as seg:
        shell = stages.estimate_shell(open_capture(capture.path, validate=False), config)
        write_json_atomic(run.shell, shell.to_json())
        numbers = {"walls": len(shell.walls), "floor_area": float(shell.polygon().area)}
        seg.log("/metrics", {"stage": Stage.SHELL, "metrics": numbers})
        return make_ref(run_dir, run.shell, "shell", numbers=numbers)


@stage_task(Stage.KEYFRAMES)
def select_keyframes(run_dir: str, capture: Ref, config: KeyFrameConfig) -> Ref:
    """Key frames by greedy 3D coverage -> keyframes.json; the reference lists the frames (``keyframes_of``)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.KEYFRAMES) as seg:
        kf = stages.select_keyframes(open_capture(capture.path, validate=False), config)
        data = kf.to_json()
        write_json_atomic(run.keyframes, data)
        frames = [int(t) for t in kf.frames]
        seg.log(
            "/hierview/keyframes", {"frames": frames, "diagnostics": {k: v for k, v in data.items() if k != "frames"}}
        )
        return make_ref(run_dir, run.keyframes, "keyframes", numbers={"count": len(frames)}, detail={"frames": frames})


@stage_task(Stage.RELATIONS, tags=("gpu",))
def predict_relations(run_dir: str, capture: Ref, shell: Ref, frame: int, config: SceneGraphConfig) -> Ref:
    """Relation inference on one key frame -> scenegraph/frames/<t>.json and its ID overlay <t>.png."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.RELATIONS, frame) as seg:
        cap = open_capture(capture.path, validate=False)
        predictor = stages.make_predictor(config)
        endpoint = str(config.vlm.base_url or "from the environment") if config.backend == "openai" else None
        with vlm_slot(endpoint) if endpoint is not None else nullcontext():
            prediction = stages.predict_frame(cap, int(frame), load_shell(run_dir, shell), config, predictor)
        transport = [
            a.transport_error for a in getattr(prediction, "attempts", ()) if getattr(a, "transport_error", None)
        ]
        if getattr(prediction, "status", "ok") == "failed" and transport:
            # the endpoint timed out or was unreachable after its own retries: retry the task with backoff
            raise TransientStageError(f"key frame {frame}: relation endpoint failed: {transport[-1]}")
        stages.write_frame(run.scenegraph, cap, prediction, config)
        seg.log("/scenegraph/frame_predictions", {"frame": int(frame), "prediction": prediction.to_json()})
        return make_ref(run_dir, run.frame_json(frame), "frame_prediction", int(frame))


@stage_task(Stage.FUSION)
def fuse_graph(
    run_dir: str, capture: Ref, shell: Ref, predictions: list[Ref], missing: list[Missing], config: SceneGraphConfig
) -> Ref:
    """Multi-frame fusion of the per-frame predictions -> scenegraph/graph.json.

    missing: the Missing records of every instance that has no pose; fusion leaves them out.
    """
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.FUSION) as seg:
        cap = open_capture(capture.path, validate=False)
        preds = [stages.frame_prediction_from_json(read_json(run.root / p.path)) for p in predictions]
        missing_ids = {int(m.instance) for m in missing}
        room = load_shell(run_dir, shell)
        graph, report = stages.fuse_with_report(preds, cap, room, config, missing_ids, stages.make_predictor(config))
        stages.write_graph(run.scenegraph, graph, cap, room, report)
        for edge in graph.edges:
            d = edge.to_json()
            seg.log(
                "/scenegraph/fusion",
                {k: d[k] for k in ("child", "relation", "parent", "confidence", "scores", "flags")},
            )
        numbers = {"edges": len(graph.edges), "uncertain": sum("uncertain" in e.flags for e in graph.edges)}
        seg.log("/metrics", {"stage": Stage.FUSION, "metrics": numbers})
        return make_ref(run_dir, run.graph, "graph", numbers=numbers)


def _placed(run_dir: str, cap, assets: list[Ref], poses: list[Ref]) -> list[SceneObject]:
    """The registered objects (asset mesh + registered pose) of every instance with an ok pose."""
    by_id = {int(a.item): a for a in assets if a.ok}
    out = []
    for p in poses:
        i = int(p.item)
        if not p.ok or i not in by_id:
            continue
        asset = load_asset_ref(run_dir, by_id[i])
        pose = Pose.from_json(read_json(Path(run_dir) / p.path)["pose"])
        out.append(
            SceneObject(
                i, cap.instance(i).label, np.asarray(asset.vertices), np.asarray(asset.faces), pose.world_from_asset
            )
        )
    return out


@stage_task(Stage.SNAPSHOT)
def snapshot_registration(
    run_dir: str, capture: Ref, shell: Ref, assets: list[Ref], poses: list[Ref], config: ExportConfig
) -> Ref:
    """A foxglove.SceneUpdate of the registered scene (before attachment) on /scene/after_registration."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SNAPSHOT) as seg:
        cap = open_capture(capture.path, validate=False)
        objects = _placed(run_dir, cap, assets, poses)
        update = scene_update(objects, load_shell(run_dir, shell), now_ns(), config.wall_height, config.wall_thickness)
        seg.log("/scene/after_registration", update)
        summary = {"objects": [o.instance for o in objects]}
        write_json_atomic(run.after_registration, summary)
        return make_ref(run_dir, run.after_registration, "snapshot", numbers={"objects": len(objects)})


@stage_task(Stage.ATTACHMENT)
def attach_layout(
    run_dir: str,
    capture: Ref,
    shell: Ref,
    graph: Ref,
    assets: list[Ref],
    poses: list[Ref],
    config: AttachmentConfig,
    export_config: ExportConfig,
) -> Ref:
    """Attachment along the scene graph -> layout.json, plus a SceneUpdate on /scene/after_attachment."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.ATTACHMENT) as seg:
        cap = open_capture(capture.path, validate=False)
        placed = _placed(run_dir, cap, assets, poses)
        objects = {
            InstanceId(o.instance): stages.assembly_object(
                o.instance,
                o.label,
                o.vertices,
                o.faces,
                o.world_from_asset,
                points=np.asarray(cap.point_cloud(o.instance).points, np.float64),
            )
            for o in placed
        }
        shell_rec = load_shell(run_dir, shell)
        scene_graph = SceneGraph.from_json(read_json(run.root / graph.path))
        # an empty scene has nothing to attach: the library is not asked to place zero objects
        layout = stages.attach(objects, scene_graph, shell_rec, config) if objects else Layout({})
        write_json_atomic(run.layout, layout.to_json())
        for op in layout.operations:
            seg.log(
                "/assembly/operations",
                {"instance": op.get("instance"), "rule": op.get("rule"), "operation": op},
            )
        final = [
            SceneObject(
                o.instance,
                o.label,
                o.vertices,
                o.faces,
                layout.world_from_asset.get(InstanceId(o.instance), o.world_from_asset),
            )
            for o in placed
        ]
        seg.log(
            "/scene/after_attachment",
            scene_update(final, shell_rec, now_ns(), export_config.wall_height, export_config.wall_thickness),
        )
        numbers = {
            "objects": len(layout.world_from_asset),
            "operations": len(layout.operations),
            "missing": len(layout.missing),
        }
        seg.log("/metrics", {"stage": Stage.ATTACHMENT, "metrics": numbers})
        return make_ref(run_dir, run.layout, "layout", numbers=numbers)


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
    """scene/scene.glb, scene/scene.json and scene/objects/ from the layout."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.EXPORT) as seg:
        cap = open_capture(capture.path, validate=False)
        layout_rec = Layout.from_json(read_json(run.root / layout.path))
        objects = placed_objects(_placed(run_dir, cap, assets, poses), layout_rec)
        all_missing = list(missing) + list(layout_rec.missing)
        hashes = export_scene(
            run.scene,
            objects,
            load_shell(run_dir, shell),
            SceneGraph.from_json(read_json(run.root / graph.path)),
            all_missing,
            config,
            extra={"scene_id": cap.scene_id, "capture": capture.path, "capture_sha256": capture.sha256},
        )
        seg.log("/metrics", {"stage": Stage.EXPORT, "metrics": {"objects": len(objects), "files": len(hashes)}})
        return make_ref(run_dir, run.scene_json, "scene", numbers={"objects": len(objects)}, detail={"files": hashes})


@stage_task(Stage.SIMCHECK)
def simcheck(run_dir: str, scene: Ref, config: SimcheckConfig) -> Ref:
    """The physics check of scene/mjcf/scene.xml -> sim/simcheck.json and sim/before_after.png."""
    from rescene_core.sim import simcheck_run

    run = RunPaths(run_dir)
    with executing(run_dir, Stage.SIMCHECK) as seg:
        result = simcheck_run(run_dir, config)
        numbers = {k: v for k, v in result.summary.items() if isinstance(v, int | float) and not isinstance(v, bool)}
        seg.log("/metrics", {"stage": Stage.SIMCHECK, "metrics": numbers})
        return make_ref(run_dir, run.simcheck, "simcheck", numbers=numbers)


@stage_task(Stage.EVALUATION)
def evaluate(run_dir: str, capture: Ref, scene: Ref, keyframes: Ref | None = None, physics: Ref | None = None) -> Ref:
    """Every metric the run allows (structural, geometry and rendering against the sensor's depth and the
    ground truth when the capture has them, the physics check's results) -> eval/metrics.json, report.md,
    report.html. ``keyframes`` and ``physics`` (sim/simcheck.json) are inputs so the cache sees them."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.EVALUATION) as seg:
        metrics = evaluate_run(run_dir, capture.path)
        flat = {k: v for k, v in metrics.get("summary", {}).items() if isinstance(v, int | float)}
        seg.log("/metrics", {"stage": Stage.EVALUATION, "metrics": flat})
        return make_ref(run_dir, run.metrics, "metrics", numbers=flat)
