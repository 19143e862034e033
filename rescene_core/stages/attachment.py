"""Stage ``attachment``: the registered objects attached along the scene graph -> layout.json."""

from __future__ import annotations

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.config import AttachmentConfig
from rescene_core.io import read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Layout, Ref, SceneGraph, Stage
from rescene_core.runlog import SceneObject, now_ns, scene_update
from rescene_core.stages import calls
from rescene_core.stages.common import load_shell, placed_objects
from rescene_core.stages.execution import executing, make_ref


def run(
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
    """The attached layout, plus a SceneUpdate on /scene/after_attachment (walls ``wall_height`` x
    ``wall_thickness`` m)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.ATTACHMENT) as seg:
        cap = open_capture(capture.path, validate=False)
        placed = placed_objects(run_dir, cap, assets, poses)
        objects = {
            InstanceId(o.instance): calls.assembly_object(
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
        layout = calls.attach(objects, scene_graph, shell_rec, config) if objects else Layout({})
        write_json_atomic(run.layout, layout.to_json())
        for op in layout.operations:
            seg.log("/assembly/operations", {"instance": op.instance, "rule": op.rule, "operation": op.to_json()})
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
        seg.log("/scene/after_attachment", scene_update(final, shell_rec, now_ns(), wall_height, wall_thickness))
        numbers = {
            "objects": len(layout.world_from_asset),
            "operations": len(layout.operations),
            "missing": len(layout.missing),
        }
        seg.log("/metrics", {"stage": Stage.ATTACHMENT, "metrics": numbers})
        return make_ref(run_dir, run.layout, "layout", numbers=numbers)
