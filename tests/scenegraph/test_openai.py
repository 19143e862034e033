import base64
import json
import logging
import threading
import time

import pytest

from rescene_core.config import SceneGraphConfig, VlmClientConfig
from rescene_core.scenegraph import TransportError, make_predictor, predict_frame
from rescene_core.scenegraph.loopback import LoopbackServer, Reply, user_text
from tests.scenegraph.test_frame import GT

KEY = "sk-test-SECRET-0123456789"


def good_answer(request):
    """A correct answer for the frame, read from the prompt's id list (the test knows the room)."""
    text = user_text(request)
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()[:1].isdigit() and ":" in ln]
    labels = {int(ln.split(":")[0]): ln.split(":", 1)[1].strip() for ln in lines}
    label_to_inst = {"table": 6, "table lamp": 7, "picture": 8, "chair": 9, "cabinet": 10}
    inst_to_disp = {label_to_inst[v]: k for k, v in labels.items()}
    out = []
    for d, label in labels.items():
        rel, parent = GT[label_to_inst[label]]
        p = parent.value if isinstance(parent, str) else inst_to_disp.get(int(parent), "floor")
        out.append({"id": d, "category": label, "relation": rel.value, "parent": p})
    return json.dumps({"objects": out})


def config(server, **kw):
    vlm = dict(base_url=server.base_url, api_key=KEY, timeout_s=2.0, backoff_s=0.01)
    vlm.update(kw)
    return SceneGraphConfig(backend="openai", vlm=VlmClientConfig(**vlm))


def scripted(*replies):
    queue = list(replies)

    def script(request):
        r = queue.pop(0) if queue else Reply(content=good_answer(request))
        return Reply(content=r(request)) if callable(r) else r

    return script


def assert_no_key(*texts):
    for t in texts:
        assert KEY not in t


def test_request_format_and_answer(room_capture, shell):
    with LoopbackServer(scripted()) as server:
        predictor = make_predictor(config(server))
        p = predict_frame(room_capture, 0, shell, config(server), predictor)
    assert p.status == "ok" and p.backend == "openai" and p.model == "Qwen/Qwen3-VL-32B-Instruct"
    assert all(p.relations[c] == GT[int(c)] for c in p.relations)
    req, headers = server.requests[0], server.headers[0]
    assert headers["Authorization"] == f"Bearer {KEY}"
    assert req["response_format"]["type"] == "json_schema"
    schema = req["response_format"]["json_schema"]["schema"]
    assert schema["properties"]["objects"]["items"]["required"] == ["id", "category", "relation", "parent"]
    url = req["messages"][1]["content"][1]["image_url"]["url"]
    assert url.startswith("data:image/png;base64,")
    assert base64.b64decode(url.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert_no_key(json.dumps(p.to_json()), repr(predictor))


def test_malformed_missing_ids_and_cycles_are_retried(room_capture, shell):
    def missing(request):
        data = json.loads(good_answer(request))
        data["objects"] = data["objects"][:1]
        return json.dumps(data)

    def cycle(request):
        data = json.loads(good_answer(request))
        ids = [o["id"] for o in data["objects"]]
        data["objects"][0]["parent"], data["objects"][1]["parent"] = ids[1], ids[0]
        return json.dumps(data)

    with LoopbackServer(scripted(Reply(content='{"objects": [{"id": 1'), missing)) as server:
        p = predict_frame(room_capture, 0, shell, config(server), make_predictor(config(server)))
    assert p.status == "ok" and p.retries == 2
    assert "not valid JSON" in p.attempts[0].errors[0] and "no entry" in " ".join(p.attempts[1].errors)
    second = user_text(server.requests[1])
    assert '{"objects": [{"id": 1' in second and "not valid JSON" in second

    with LoopbackServer(scripted(cycle, cycle, cycle)) as server:
        p = predict_frame(room_capture, 0, shell, config(server), make_predictor(config(server)))
    assert p.status == "partial" and p.retries == 2 and "cycle" in " ".join(p.attempts[-1].errors)
    assert len(p.relations) == len(p.visible) - 2


def test_http_500_and_429_are_retried_with_backoff(room_capture, shell):
    with LoopbackServer(scripted(Reply(status=500, body="boom"), Reply(status=429, body="slow down"))) as server:
        cfg = config(server)
        predictor = make_predictor(cfg)
        p = predict_frame(room_capture, 0, shell, cfg, predictor)
    assert p.status == "ok" and predictor.stats["transport_retries"] == 2 and predictor.stats["calls"] == 3


def test_timeouts_end_the_frame_after_the_transport_retries(room_capture, shell, caplog):
    slow = Reply(content="{}", delay_s=1.0)
    with LoopbackServer(scripted(slow, slow, slow)) as server:
        cfg = config(server, timeout_s=0.2, transport_retries=1)
        predictor = make_predictor(cfg)
        start = time.perf_counter()
        with caplog.at_level(logging.WARNING):
            p = predict_frame(room_capture, 0, shell, cfg, predictor)
        elapsed = time.perf_counter() - start
    assert p.status == "failed" and p.relations == {}
    assert "timed out" in p.attempts[0].transport_error and elapsed < 3.0
    assert predictor.stats["calls"] == 2 and predictor.stats["transport_failures"] == 1
    assert "retrying" in caplog.text


def test_api_key_never_leaks_even_when_the_server_echoes_it(room_capture, shell, caplog):
    from rescene_core.scenegraph import Query
    from rescene_core.scenegraph.view import frame_view

    echo = Reply(status=500, body=f"upstream rejected Authorization: Bearer {KEY}")
    denied = Reply(status=401, body=f"invalid key {KEY}")
    with LoopbackServer(scripted(echo, denied, denied)) as server:
        cfg = config(server, transport_retries=1)
        predictor = make_predictor(cfg)
        with caplog.at_level(logging.DEBUG):
            p = predict_frame(room_capture, 0, shell, cfg, predictor)
            query = Query("relations", "s", "p", b"", {}, frame_view(room_capture, 0, cfg), room_capture, shell)
            with pytest.raises(TransportError) as err:
                predictor.answer(query)
    assert p.status == "failed" and "401" in p.attempts[0].transport_error
    assert "[redacted]" in p.attempts[0].transport_error and "[redacted]" in str(err.value)
    assert_no_key(json.dumps(p.to_json()), str(err.value), repr(err.value), caplog.text, repr(cfg))
    assert_no_key(json.dumps(cfg.model_dump()), repr(predictor))


def test_one_client_per_config_and_key():
    base = dict(backend="openai", vlm=VlmClientConfig(base_url="http://127.0.0.1:9/v1", api_key="key-a"))
    same = make_predictor(SceneGraphConfig(**base))
    assert make_predictor(SceneGraphConfig(**base)) is same  # built once per process
    other = make_predictor(
        SceneGraphConfig(**base | {"vlm": VlmClientConfig(base_url="http://127.0.0.1:9/v1", api_key="key-b")})
    )
    assert other is not same  # the key is excluded from the config's JSON but still tells clients apart


def test_api_key_from_environment(room_capture, shell, monkeypatch):
    monkeypatch.setenv("RESCENE_VLM_API_KEY", KEY)
    with LoopbackServer(scripted()) as server:
        monkeypatch.setenv("RESCENE_VLM_BASE_URL", server.base_url)
        cfg = SceneGraphConfig(backend="openai")
        p = predict_frame(room_capture, 1, shell, cfg, make_predictor(cfg))
    assert p.status == "ok" and server.headers[0]["Authorization"] == f"Bearer {KEY}"


def test_concurrency_is_bounded(room_capture, shell):
    from rescene_core.scenegraph import predict_frames

    active = {"now": 0, "max": 0}
    lock = threading.Lock()

    def script(request):
        with lock:
            active["now"] += 1
            active["max"] = max(active["max"], active["now"])
        time.sleep(0.05)
        with lock:
            active["now"] -= 1
        return Reply(content=good_answer(request))

    with LoopbackServer(script) as server:
        cfg = config(server, max_concurrency=2)
        preds = predict_frames(room_capture, list(range(room_capture.num_frames)), shell, cfg, make_predictor(cfg))
    assert all(p.status == "ok" for p in preds)
    assert active["max"] <= 2 and len(server.requests) == room_capture.num_frames
