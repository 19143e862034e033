"""Scene-level tasks: room shell, key frames, per-frame relations, fusion, attachment, export, evaluation.

Each loads its inputs from the run directory, calls one library function, writes its output atomically
and returns a reference (see tasks/common.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import AttachmentConfig, KeyFrameConfig, SceneGraphConfig, ShellConfig
from rescene_core.export import ExportConfig, ExportObject, export_scene
from rescene_core.io import read_json, write_json_atomic
from rescene_core.records import InstanceId, Layout, Missing, Pose, RoomShell, SceneGraph
from rescene_core.runlog import SceneObject, now_ns, scene_update
from tasks import stages
from tasks.common import TransientStageError, executing, make_ref, stage_task
from tasks.instance import load_asset_ref


@stage_task("validate", retries=0)
def validate_capture(capture: dict[str, Any]) -> dict[str, Any]:
    """Validate the capture (raises CaptureError listing every problem); cached on its content hash."""
    cap = open_capture(capture["path"], validate=True)
    return {**capture, "numbers": {"frames": cap.num_frames, "instances": len(cap.instances)}}


def load_shell(run_dir: str, ref: dict[str, Any]) -> RoomShell:
    return RoomShell.from_json(read_json(Path(run_dir) / ref["path"]))


@stage_task("shell")
def estimate_shell(run_dir: str, capture: dict[str, Any], config: ShellConfig) -> dict[str, Any]:
    """Room shell -> shell.json."""
    with executing(run_dir, "shell") as seg:
        shell = stages.estimate_shell(open_capture(capture["path"], validate=False), config)
        write_json_atomic(Path(run_dir) / "shell.json", shell.to_json())
        numbers = {"walls": len(shell.walls), "floor_area": float(shell.polygon().area)}
        seg.log("/metrics", {"stage": "shell", "metrics": numbers})
        return make_ref(run_dir, "shell.json", "shell", numbers=numbers)


@stage_task("keyframes")
def select_keyframes(run_dir: str, capture: dict[str, Any], config: KeyFrameConfig) -> dict[str, Any]:
    """Key frames by greedy 3D coverage -> keyframes.json; the reference lists the frames."""
    with executing(run_dir, "keyframes") as seg:
        kf = stages.select_keyframes(open_capture(capture["path"], validate=False), config)
        data = kf.to_json()
        write_json_atomic(Path(run_dir) / "keyframes.json", data)
        frames = [int(t) for t in kf.frames]
        seg.log(
            "/hierview/keyframes", {"frames": frames, "diagnostics": {k: v for k, v in data.items() if k != "frames"}}
        )
        return make_ref(run_dir, "keyframes.json", "keyframes", numbers={"count": len(frames)}, frames=frames)


@stage_task("relations", tags=("gpu",))
def predict_relations(
    run_dir: str, capture: dict[str, Any], shell: dict[str, Any], frame: int, config: SceneGraphConfig
) -> dict[str, Any]:
    """Relation inference on one key frame -> scenegraph/frames/<t>.json and its ID overlay <t>.png."""
    rel = f"scenegraph/frames/{int(frame)}.json"
    with executing(run_dir, "relations", frame) as seg:
        cap = open_capture(capture["path"], validate=False)
        predictor = stages.make_predictor(config)
        prediction = stages.predict_frame(cap, int(frame), load_shell(run_dir, shell), config, predictor)
        transport = [
            a.transport_error for a in getattr(prediction, "attempts", ()) if getattr(a, "transport_error", None)
        ]
        if getattr(prediction, "status", "ok") == "failed" and transport:
            # the endpoint timed out or was unreachable after its own retries: retry the task with backoff
            raise TransientStageError(f"key frame {frame}: relation endpoint failed: {transport[-1]}")
        stages.write_frame(Path(run_dir) / "scenegraph", cap, prediction, config)
        seg.log("/scenegraph/frame_predictions", {"frame": int(frame), "prediction": prediction.to_json()})
        return make_ref(run_dir, rel, "frame_prediction", int(frame))


@stage_task("fusion")
def fuse_graph(
    run_dir: str,
    capture: dict[str, Any],
    shell: dict[str, Any],
    predictions: list[dict[str, Any]],
    missing: list[dict[str, Any]],
    config: SceneGraphConfig,
) -> dict[str, Any]:
    """Multi-frame fusion of the per-frame predictions -> scenegraph/graph.json.

    missing: Missing records (JSON) of every instance that has no pose; fusion leaves them out.
    """
    with executing(run_dir, "fusion") as seg:
        cap = open_capture(capture["path"], validate=False)
        preds = [stages.frame_prediction_from_json(read_json(Path(run_dir) / p["path"])) for p in predictions]
        missing_ids = {int(m["instance"]) for m in missing}
        room = load_shell(run_dir, shell)
        graph, report = stages.fuse_with_report(preds, cap, room, config, missing_ids, stages.make_predictor(config))
        stages.write_graph(Path(run_dir) / "scenegraph", graph, cap, room, report)
        for edge in graph.edges:
            d = edge.to_json()
            seg.log(
                "/scenegraph/fusion",
                {k: d[k] for k in ("child", "relation", "parent", "confidence", "scores", "flags")},
            )
        numbers = {"edges": len(graph.edges), "uncertain": sum("uncertain" in e.flags for e in graph.edges)}
        seg.log("/metrics", {"stage": "fusion", "metrics": numbers})
        return make_ref(run_dir, "scenegraph/graph.json", "graph", numbers=numbers)


def _placed(run_dir: str, cap, assets: list[dict[str, Any]], poses: list[dict[str, Any]]) -> list[SceneObject]:
    """The registered objects (asset mesh + registered pose) of every instance with an ok pose."""
    by_id = {int(a["item"]): a for a in assets if a["status"] == "ok"}
    out = []
    for p in poses:
        i = int(p["item"])
        if p["status"] != "ok" or i not in by_id:
            continue
        asset = load_asset_ref(run_dir, by_id[i])
        pose = Pose.from_json(read_json(Path(run_dir) / p["path"])["pose"])
        out.append(
            SceneObject(
                i, cap.instance(i).label, np.asarray(asset.vertices), np.asarray(asset.faces), pose.world_from_asset
            )
        )
    return out


@stage_task("snapshot")
def snapshot_registration(
    run_dir: str,
    capture: dict[str, Any],
    shell: dict[str, Any],
    assets: list[dict[str, Any]],
    poses: list[dict[str, Any]],
    config: ExportConfig,
) -> dict[str, Any]:
    """A foxglove.SceneUpdate of the registered scene (before attachment) on /scene/after_registration."""
    with executing(run_dir, "snapshot") as seg:
        cap = open_capture(capture["path"], validate=False)
        objects = _placed(run_dir, cap, assets, poses)
        update = scene_update(objects, load_shell(run_dir, shell), now_ns(), config.wall_height, config.wall_thickness)
        seg.log("/scene/after_registration", update)
        summary = {"objects": [o.instance for o in objects]}
        write_json_atomic(Path(run_dir) / "logs/after_registration.json", summary)
        return make_ref(run_dir, "logs/after_registration.json", "snapshot", numbers={"objects": len(objects)})


@stage_task("attachment")
def attach_layout(
    run_dir: str,
    capture: dict[str, Any],
    shell: dict[str, Any],
    graph: dict[str, Any],
    assets: list[dict[str, Any]],
    poses: list[dict[str, Any]],
    config: AttachmentConfig,
    export_config: ExportConfig,
) -> dict[str, Any]:
    """Attachment along the scene graph -> layout.json, plus a SceneUpdate on /scene/after_attachment."""
    with executing(run_dir, "attachment") as seg:
        cap = open_capture(capture["path"], validate=False)
        placed = _placed(run_dir, cap, assets, poses)
        objects = {
            InstanceId(o.instance): stages.assembly_object(o.instance, o.label, o.vertices, o.faces, o.world_from_asset)
            for o in placed
        }
        shell_rec = load_shell(run_dir, shell)
        scene_graph = SceneGraph.from_json(read_json(Path(run_dir) / graph["path"]))
        # an empty scene has nothing to attach: the library is not asked to place zero objects
        layout = stages.attach(objects, scene_graph, shell_rec, config) if objects else Layout({})
        write_json_atomic(Path(run_dir) / "layout.json", layout.to_json())
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
        seg.log("/metrics", {"stage": "attachment", "metrics": numbers})
        return make_ref(run_dir, "layout.json", "layout", numbers=numbers)


@stage_task("export")
def export(
    run_dir: str,
    capture: dict[str, Any],
    shell: dict[str, Any],
    graph: dict[str, Any],
    layout: dict[str, Any],
    assets: list[dict[str, Any]],
    poses: list[dict[str, Any]],
    missing: list[dict[str, Any]],
    config: ExportConfig,
) -> dict[str, Any]:
    """scene/scene.glb, scene/scene.json and scene/objects/ from the layout."""
    with executing(run_dir, "export") as seg:
        cap = open_capture(capture["path"], validate=False)
        layout_rec = Layout.from_json(read_json(Path(run_dir) / layout["path"]))
        objects = [
            ExportObject(
                o.instance,
                o.label,
                o.vertices,
                o.faces,
                layout_rec.world_from_asset.get(InstanceId(o.instance), o.world_from_asset),
                o.world_from_asset,
            )
            for o in _placed(run_dir, cap, assets, poses)
        ]
        all_missing = [Missing.from_json(m) for m in missing] + list(layout_rec.missing)
        hashes = export_scene(
            Path(run_dir) / "scene",
            objects,
            load_shell(run_dir, shell),
            SceneGraph.from_json(read_json(Path(run_dir) / graph["path"])),
            all_missing,
            config,
            extra={"scene_id": cap.scene_id, "capture": capture["path"], "capture_sha256": capture["sha256"]},
        )
        seg.log("/metrics", {"stage": "export", "metrics": {"objects": len(objects), "files": len(hashes)}})
        return make_ref(run_dir, "scene/scene.json", "scene", numbers={"objects": len(objects)}, files=hashes)


@stage_task("evaluation")
def evaluate(run_dir: str, capture: dict[str, Any], scene: dict[str, Any]) -> dict[str, Any]:
    """Metrics against the capture's ground truth -> eval/metrics.json and eval/report.md."""
    from rescene_core.evaluation import evaluate_run

    with executing(run_dir, "evaluation") as seg:
        metrics = evaluate_run(run_dir, capture["path"])
        flat = {k: v for k, v in metrics.get("summary", {}).items() if isinstance(v, int | float)}
        seg.log("/metrics", {"stage": "evaluation", "metrics": flat})
        return make_ref(run_dir, "eval/metrics.json", "metrics", numbers=flat)
