"""The perceptual judge against a scripted OpenAI-compatible loopback endpoint (not a model)."""

from __future__ import annotations

import json
import socket

import pytest

from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation.geometry import GeometryConfig
from rescene_core.evaluation.judge import AXES, RUBRIC, JudgeConfig, judge, parse_answer
from rescene_core.evaluation.rendering import RenderingConfig
from rescene_core.evaluation.run import EvaluationConfig
from rescene_core.scenegraph.loopback import LoopbackServer, Reply
from tests.evaluation.scene import write_test_capture, write_test_run

GOOD = json.dumps({a: {"score": 4, "comment": "fine"} for a in AXES})
PNG = [b"\x89PNG fake-1", b"\x89PNG fake-2", b"\x89PNG fake-3"]


def _images(request) -> list[str]:
    parts = request["messages"][1]["content"]
    return [p["image_url"]["url"] for p in parts if p["type"] == "image_url"]


def test_parse_answer_is_strict():
    assert parse_answer(GOOD)[0] is not None
    assert parse_answer("```json\n" + GOOD + "\n```")[0] is None
    bad = json.loads(GOOD)
    bad["visual_fidelity"]["score"] = 6
    assert "integer 1-5" in parse_answer(json.dumps(bad))[1][0]
    bad = json.loads(GOOD)
    bad["visual_fidelity"]["score"] = 4.0
    assert parse_answer(json.dumps(bad))[0] is None
    bad = json.loads(GOOD)
    del bad["aesthetic_quality"]
    assert parse_answer(json.dumps(bad))[0] is None


def test_scores_come_back_with_the_rubric_and_every_image():
    with LoopbackServer(lambda r: Reply(GOOD)) as server:
        out = judge(PNG, rendered=2, config=JudgeConfig(base_url=server.base_url, model="judge-test"))
    assert out["status"] == "ok" and out["scores"] == dict.fromkeys(AXES, 4) and out["attempts"] == 1
    request = server.requests[0]
    assert request["model"] == "judge-test"
    assert request["messages"][0]["content"] == RUBRIC
    assert len(_images(request)) == 3
    assert request["response_format"]["type"] == "json_schema"
    assert "Images 1-2 are rendered views" in request["messages"][1]["content"][0]["text"]


def test_malformed_answers_are_retried_with_their_errors():
    answers = iter(["not json", json.dumps({"visual_fidelity": {"score": 9, "comment": ""}}), GOOD])
    with LoopbackServer(lambda r: Reply(next(answers))) as server:
        out = judge(PNG, rendered=3, config=JudgeConfig(base_url=server.base_url, retries=2))
    assert out["status"] == "ok" and out["attempts"] == 3
    assert "not valid JSON" in server.requests[1]["messages"][1]["content"][0]["text"]
    with LoopbackServer(lambda r: Reply("{}")) as server:
        out = judge(PNG, rendered=3, config=JudgeConfig(base_url=server.base_url, retries=1))
    assert out["status"] == "failed" and out["attempts"] == 2 and "no valid answer" in out["reason"]


def _closed_port() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}/v1"


@pytest.mark.slow
def test_endpoint_down_fails_the_judge_not_the_evaluation(tmp_path):
    capture = write_test_capture(tmp_path / "room.zarr")
    run = write_test_run(tmp_path / "run", capture)
    config = EvaluationConfig(
        html=False,
        rendering=RenderingConfig(scale=1.0),
        geometry=GeometryConfig(fuse_scale=1.0),
        judge=JudgeConfig(base_url=_closed_port(), transport_retries=1, backoff_s=0.01, views=2, key_frames=1),
    )
    m = evaluate_run(run, config=config)
    assert m["judge"]["status"] == "failed" and "endpoint failed" in m["judge"]["reason"]
    assert m["not_computed"]["judge"] == m["judge"]["reason"]
    assert m["geometry"]["ground_truth"]["sampled"]["fscore@5cm"] == 1.0
    assert m["rendering"]["psnr_masked"] is not None
    # the same run against a working endpoint: rendered views and key frames go out, scores come back
    with LoopbackServer(lambda r: Reply(GOOD)) as server:
        m = evaluate_run(
            run,
            config=config.model_copy(update={"judge": JudgeConfig(base_url=server.base_url, views=2, key_frames=1)}),
        )
    assert m["judge"]["status"] == "ok" and m["summary"]["judge_visual_fidelity"] == 4
    assert m["judge"]["images"] == ["figures/view_0.png", "figures/view_1.png", "figures/keyframe_0.png"]
    assert len(_images(server.requests[0])) == 3
    assert all((run / "eval" / name).exists() for name in m["judge"]["images"])


def test_off_unless_configured(monkeypatch):
    monkeypatch.delenv("RESCENE_JUDGE_BASE_URL", raising=False)
    assert JudgeConfig().endpoint() is None
