"""Stage ``fusion``: multi-frame fusion of the per-frame predictions -> scenegraph/graph.json (and graph.png)."""

from __future__ import annotations

from rescene_core.capture import open_capture
from rescene_core.config import SceneGraphConfig
from rescene_core.io import read_json
from rescene_core.paths import RunPaths
from rescene_core.records import Missing, Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.common import load_shell
from rescene_core.stages.execution import executing, make_ref


def run(
    run_dir: str, capture: Ref, shell: Ref, predictions: list[Ref], missing: list[Missing], config: SceneGraphConfig
) -> Ref:
    """The fused scene graph; ``missing``: the Missing record of every instance without a pose (left out)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.FUSION) as seg:
        cap = open_capture(capture.path, validate=False)
        preds = [calls.frame_prediction_from_json(read_json(run.root / p.path)) for p in predictions]
        missing_ids = {int(m.instance) for m in missing}
        room = load_shell(run_dir, shell)
        graph, report = calls.fuse_with_report(preds, cap, room, config, missing_ids, calls.make_predictor(config))
        calls.write_graph(run.scenegraph, graph, cap, room, report)
        for edge in graph.edges:
            d = edge.to_json()
            seg.log(
                "/scenegraph/fusion",
                {k: d[k] for k in ("child", "relation", "parent", "confidence", "scores", "flags")},
            )
        numbers = {"edges": len(graph.edges), "uncertain": sum("uncertain" in e.flags for e in graph.edges)}
        seg.log("/metrics", {"stage": Stage.FUSION, "metrics": numbers})
        return make_ref(run_dir, run.graph, "graph", numbers=numbers)
