import json

import pytest

from rescene_core.config import SceneGraphConfig
from rescene_core.records import Relation, Root
from rescene_core.scenegraph import FramePrediction, make_predictor, predict_frame, predict_frames
from rescene_core.scenegraph.backend import RelationPredictor
from tests.scenegraph.room import GT


class Scripted:
    """An in-process predictor that replays answers (functions of the query)."""

    backend = "scripted"
    model = "scripted"
    supports_ab = False

    def __init__(self, answers):
        self.answers = list(answers)
        self.prompts = []

    def answer(self, query):
        self.prompts.append(query.prompt)
        a = self.answers.pop(0)
        return a(query) if callable(a) else a


def correct(query):
    to_inst = query.view.display_to_instance
    to_disp = query.view.instance_to_display
    out = []
    for d, iid in to_inst.items():
        rel, parent = GT[int(iid)]
        p = parent.value if isinstance(parent, Root) else to_disp.get(parent, "floor")
        out.append({"id": d, "category": query.view.categories[d], "relation": rel.value, "parent": p})
    return json.dumps({"objects": out})


def test_geometric_backend_reads_each_frame(room_capture, shell):
    cfg = SceneGraphConfig()
    predictor = make_predictor(cfg)
    assert isinstance(predictor, RelationPredictor) and predictor.backend == "geometric"
    preds = predict_frames(room_capture, list(range(room_capture.num_frames)), shell, cfg, predictor)
    right = total = 0
    for p in preds:
        assert p.status == "ok" and p.retries == 0
        for child, got in p.relations.items():
            total += 1
            right += got == GT[int(child)]
    assert total >= 25 and right / total >= 0.85
    # the lamp is on the table in every frame that shows both
    assert all(p.relations[7] == (Relation.RESTS_ON, 6) for p in preds if 7 in p.relations and 6 in p.relations)


def test_frame_prediction_round_trips(room_capture, shell):
    cfg = SceneGraphConfig()
    p = predict_frame(room_capture, 2, shell, cfg, make_predictor(cfg))
    data = json.loads(json.dumps(p.to_json()))
    q = FramePrediction.from_json(data)
    assert q.relations == p.relations and q.visible == p.visible and q.status == p.status
    assert data["attempts"][0]["prompt"] and data["attempts"][0]["raw"]
    assert set(map(int, data["display_to_instance"].values())) == {int(v.instance) for v in p.visible}


def test_validation_retry_carries_errors_and_previous_answer(room_capture, shell):
    cfg = SceneGraphConfig()
    predictor = Scripted(['{"objects": [', correct])
    p = predict_frame(room_capture, 0, shell, cfg, predictor)
    assert p.status == "ok" and p.retries == 1 and len(p.attempts) == 2
    assert "not valid JSON" in p.attempts[0].errors[0]
    assert '{"objects": [' in predictor.prompts[1] and "not valid JSON" in predictor.prompts[1]
    assert all(p.relations[c] == GT[int(c)] for c in p.relations if GT[int(c)][1] != 10)


def test_retry_budget_is_two_then_partial_or_failed(room_capture, shell):
    cfg = SceneGraphConfig()
    bad = Scripted(["nope"] * 5)
    p = predict_frame(room_capture, 0, shell, cfg, bad)
    assert p.status == "failed" and len(p.attempts) == cfg.vlm.retry_budget + 1 and p.relations == {}

    def one_missing(query):
        data = json.loads(correct(query))
        data["objects"] = data["objects"][:-1]
        return json.dumps(data)

    p = predict_frame(room_capture, 0, shell, cfg, Scripted([one_missing] * 3))
    assert p.status == "partial" and p.retries == 2
    assert len(p.relations) == len(p.visible) - 1


def test_predict_frame_rejects_bad_frame(room_capture, shell):
    cfg = SceneGraphConfig()
    with pytest.raises(ValueError, match="outside"):
        predict_frame(room_capture, 99, shell, cfg, make_predictor(cfg))


def test_unknown_backend_is_a_clear_error():
    with pytest.raises(ValueError, match="base URL|endpoint"):
        make_predictor(SceneGraphConfig(backend="openai"))
