"""End to end on a real synthetic capture: estimated shell, greedy key frames, geometric backend, fusion."""

import pytest

from rescene_core.bench.scenegraph import anchor_resolved, edge_accuracy
from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.config import KeyFrameConfig, SceneGraphConfig, ShellConfig
from rescene_core.scenegraph import fuse_with_report, make_predictor, predict_frames, write_frame, write_graph


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    from rescene_core.capture.synth import write_synth

    path = write_synth(tmp_path_factory.mktemp("synth") / "tiny.zarr", preset="tiny", seed=0)
    return open_capture(path)


def test_fusion_on_a_synthetic_scene(tiny, tmp_path):
    from rescene_core.hierview import select_keyframes
    from rescene_core.shell import estimate_shell

    gt = read_ground_truth(tiny)
    shell = estimate_shell(tiny, ShellConfig())
    frames = list(select_keyframes(tiny, KeyFrameConfig()).frames)
    cfg = SceneGraphConfig()
    preds = predict_frames(tiny, frames, shell, cfg, make_predictor(cfg))
    assert all(p.status in ("ok", "empty") for p in preds)
    graph, report = fuse_with_report(preds, tiny, shell, cfg)
    vote, _ = fuse_with_report(preds, tiny, shell, cfg, variant="vote")
    children = [int(i.id) for i in tiny.object_instances]
    edges = {int(e.child): (e.relation, e.parent) for e in graph.edges}
    vote_edges = {int(e.child): (e.relation, e.parent) for e in vote.edges}
    gt_graph = gt.graph_by_instance()
    acc = edge_accuracy(edges, gt_graph, gt.object_of_instance())
    assert graph.check() == [] and sorted(edges) == sorted(children)
    assert anchor_resolved(edges, children) == 1.0
    assert acc >= 0.95 and acc >= edge_accuracy(vote_edges, gt_graph, gt.object_of_instance())
    write_frame(tmp_path, tiny, preds[0], cfg)
    write_graph(tmp_path, graph, tiny, shell, report)
    assert (tmp_path / "frames" / f"{preds[0].frame}.png").exists()
    assert (tmp_path / "frames" / f"{preds[0].frame}.json").exists() and (tmp_path / "graph.png").exists()
