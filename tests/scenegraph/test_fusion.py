import json

import pytest

from rescene_core.config import FusionConfig, SceneGraphConfig
from rescene_core.records import InstanceId, Relation, Root
from rescene_core.scenegraph import FramePrediction, fuse, fuse_with_report, make_predictor, predict_frames, write_graph
from rescene_core.scenegraph.view import VisibleInstance
from tests.scenegraph.room import GT


@pytest.fixture(scope="module")
def predictions(room_capture, shell):
    cfg = SceneGraphConfig()
    return predict_frames(room_capture, list(range(room_capture.num_frames)), shell, cfg, make_predictor(cfg))


def fake(frame, relations, visible=(6, 7, 8, 9, 10)):
    vis = tuple(VisibleInstance(InstanceId(i), k + 1, "x", 500) for k, i in enumerate(visible))
    return FramePrediction(frame, "scripted", "scripted", vis, relations, "ok")


def test_fusion_recovers_the_room(room_capture, shell, predictions):
    graph, report = fuse_with_report(predictions, room_capture, shell, SceneGraphConfig())
    assert graph.check() == []
    got = {int(e.child): (e.relation, e.parent) for e in graph.edges}
    assert got == {c: (r, p) for c, (r, p) in GT.items()}
    for e in graph.edges:
        assert set(e.scores) >= {"V", "G", "Phi", "shell", "S"} and 0.0 <= e.confidence <= 1.0
        w = report.weights
        assert e.scores["S"] == pytest.approx(
            w["V"] * e.scores["V"]
            + w["G"] * e.scores["G"]
            + w["Phi"] * e.scores["Phi"]
            + w["shell"] * e.scores["shell"]
        )
    assert report.weights == pytest.approx({"V": 0.51, "G": 0.2125, "Phi": 0.1275, "shell": 0.15})
    picture = graph.parent_of()[InstanceId(8)]
    assert picture.wall_id == 3  # the wall at y = 4


def test_weights_without_shell(room_capture, predictions):
    graph, report = fuse_with_report(predictions, room_capture, None, SceneGraphConfig())
    assert report.weights == pytest.approx({"V": 0.6, "G": 0.25, "Phi": 0.15, "shell": 0.0}) and not report.shell_prior
    assert graph.check() == []


def test_geometry_overrules_a_minority_of_wrong_votes(room_capture, shell):
    right = {6: (Relation.RESTS_ON, Root.FLOOR), 7: (Relation.RESTS_ON, InstanceId(6))}
    wrong = {6: (Relation.RESTS_ON, Root.FLOOR), 7: (Relation.MOUNTS_ON, Root.WALL)}
    preds = [fake(0, right, (6, 7)), fake(1, wrong, (6, 7)), fake(2, wrong, (6, 7)), fake(3, right, (6, 7))]
    full = fuse(preds, room_capture, shell, SceneGraphConfig())
    assert full.parent_of()[InstanceId(7)].parent == InstanceId(6)
    edge = full.parent_of()[InstanceId(7)]
    assert edge.scores["V"] == pytest.approx(0.5)


def test_cycles_are_broken_and_every_instance_gets_one_parent(room_capture, shell):
    loop = {6: (Relation.RESTS_ON, InstanceId(7)), 7: (Relation.RESTS_ON, InstanceId(6))}
    preds = [fake(t, loop, (6, 7)) for t in range(3)]
    graph, report = fuse_with_report(preds, room_capture, shell, SceneGraphConfig(), variant="vote")
    assert graph.check() == [] and report.cycles_broken
    assert {int(e.child) for e in graph.edges} == {6, 7, 8, 9, 10}
    graph = fuse(preds, room_capture, shell, SceneGraphConfig())
    assert graph.check() == []
    assert graph.parent_of()[InstanceId(6)].parent == Root.FLOOR


def test_missing_instances_get_no_edge_but_their_children_keep_them_as_parent(room_capture, shell, predictions):
    """The table (6) failed registration: it gets no edge, and the lamp standing on it keeps ``rests-on 6``
    (flag 'parent-missing'), not a floor or wall edge its evidence contradicts (the solver then leaves the
    lamp at its registered pose)."""
    graph, report = fuse_with_report(predictions, room_capture, shell, SceneGraphConfig(), missing={6})
    children = {int(e.child) for e in graph.edges}
    assert 6 not in children and children == {7, 8, 9, 10}
    lamp = graph.parent_of()[InstanceId(7)]
    assert (lamp.relation, lamp.parent) == (Relation.RESTS_ON, InstanceId(6))
    assert "parent-missing" in lamp.flags and report.parent_missing == [7]
    assert lamp.confidence > 0.8 and lamp.scores["V"] > 0.5
    assert all("parent-missing" not in e.flags for e in graph.edges if e.child != InstanceId(7))
    # the only thing SceneGraph.check() reports is that dangling edge
    assert graph.check() == ["instance 7 has parent 6, which has no edge to a root"]
    assert report.to_json()["parent_missing"] == [7]


def test_unobserved_and_uncertain_flags(room_capture, shell):
    preds = [fake(0, {9: (Relation.RESTS_ON, Root.FLOOR)}, (9,))]
    graph, report = fuse_with_report(preds, room_capture, shell, SceneGraphConfig())
    edges = graph.parent_of()
    assert "unobserved" in edges[InstanceId(7)].flags and 7 in report.unobserved
    assert edges[InstanceId(7)].parent == InstanceId(6)  # geometric proposal, never voted
    low = [e for e in graph.edges if e.confidence < 0.65]
    assert low and all("uncertain" in e.flags for e in low)
    assert set(report.low_confidence) == {int(e.child) for e in graph.edges if e.confidence < 0.60}


class ABPredictor:
    backend, model, supports_ab = "scripted", "scripted", True

    def __init__(self, choice):
        self.choice, self.prompts = choice, []

    def answer(self, query):
        assert query.kind == "ab"
        self.prompts.append(query.prompt)
        return json.dumps({"answer": self.choice})


def test_ab_reranking_accepts_only_answers_geometry_does_not_contradict(room_capture, shell):
    # the lamp: half the frames say table, half say wall -> uncertain
    a = {7: (Relation.RESTS_ON, InstanceId(6)), 6: (Relation.RESTS_ON, Root.FLOOR)}
    b = {7: (Relation.MOUNTS_ON, Root.WALL), 6: (Relation.RESTS_ON, Root.FLOOR)}
    preds = [fake(t, a if t % 2 else b, (6, 7)) for t in range(4)]
    cfg = SceneGraphConfig(fusion=FusionConfig(uncertain_top=0.99))
    for choice in ("A", "B"):
        predictor = ABPredictor(choice)
        graph, report = fuse_with_report(preds, room_capture, shell, cfg, predictor=predictor)
        lamp = graph.parent_of()[InstanceId(7)]
        assert "ab-rechecked" in lamp.flags and predictor.prompts
        assert "Which statement is true?" in predictor.prompts[0]
        # the table (G high) wins either way: choosing the wall is contradicted by geometry
        assert lamp.parent == InstanceId(6)
    rec = [r for r in report.ab if r["child"] == 7][0]
    assert rec["votes"]["B"] >= 1 or rec["kept"] == "A"


def test_graph_files(tmp_path, room_capture, shell, predictions):
    graph, report = fuse_with_report(predictions, room_capture, shell, SceneGraphConfig())
    path = write_graph(tmp_path, graph, room_capture, shell, report)
    data = json.loads(path.read_text())
    assert data["nodes"]["7"] == "table lamp" and data["report"]["variant"] == "full"
    assert {"V", "G", "Phi", "shell", "S"} <= set(data["edges"][0]["scores"])
    assert (tmp_path / "graph.png").read_bytes()[:4] == b"\x89PNG"
