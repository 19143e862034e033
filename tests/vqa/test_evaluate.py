"""`rescene vqa eval` against a scripted OpenAI-compatible server on 127.0.0.1 built here: choice parsing,
retries, time-outs and off-format replies counted as unanswered, baselines, the Table 4 layout."""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from flows.cli import main
from rescene_core.vqa.evaluate import baselines, evaluate_dataset, parse_choice, read_split, table4_markdown

CHOICES = ["lamp", "table lamp", "sofa", "2"]


@pytest.mark.parametrize(
    ("reply", "index"),
    [
        ("B", 1),
        ("(c)", None),  # lower-case letters are words, not choices
        ("(C)", 2),
        ("C. sofa", 2),
        ("Answer: D", 3),
        ("The answer is (A).", 0),
        ('{"answer": "B"}', 1),
        ("**D**", 3),
        ("table lamp", 1),  # the longer choice wins over 'lamp' inside it
        ("The Lamp.", 0),
        ("I think it is the sofa", 2),
        ("lamp or sofa", None),
        ("E", None),
        ("", None),
        ("no idea", None),
    ],
)
def test_parse_choice(reply, index):
    assert parse_choice(reply, CHOICES) == index


class Script:
    """Replies by the question: correct in several formats, wrong, off-format once, always off-format, too
    slow; HTTP 500 on the very first request; the blind run of a question with an image always says 'A'."""

    def __init__(self, records):
        self.prompts = sorted({r["prompt"] for r in records})
        self.letter = {}
        for r in records:
            self.letter.setdefault(r["prompt"], r["answer_letter"])
        self.choices = {r["prompt"]: r["choices"] for r in records}
        self.with_image = {r["prompt"] for r in records if r["image"]}
        pictured = [p for p in self.prompts if p in self.with_image]
        self.special = {pictured[0]: 10, pictured[1]: 11}  # 10: always too slow, 11: always off-format
        self.seen: dict[str, int] = {}
        self.requests = 0
        self.lock = threading.Lock()

    def mode(self, prompt: str) -> int:
        return self.special.get(prompt, self.prompts.index(prompt) % 5)

    def reply(self, body) -> tuple[int, str | None, float]:
        content = body["messages"][-1]["content"]
        prompt = next(p["text"] for p in content if p["type"] == "text")
        has_image = any(p["type"] == "image_url" for p in content)
        with self.lock:
            self.requests += 1
            first = self.requests == 1
            self.seen[prompt] = self.seen.get(prompt, 0) + 1
            times = self.seen[prompt]
        if first:
            return 500, None, 0.0
        if not has_image and prompt in self.with_image:
            return 200, "A", 0.0  # the blind run of a question that has an image
        letter, mode = self.letter[prompt], self.mode(prompt)
        choice = self.choices[prompt][ord(letter) - ord("A")]
        wrong = chr(ord("A") + (ord(letter) - ord("A") + 1) % len(self.choices[prompt]))
        return {
            10: (200, letter, 3.0),
            11: (200, "I cannot tell from this picture.", 0.0),
            0: (200, f"The answer is ({letter}).", 0.0),
            1: (200, choice, 0.0),
            2: (200, json.dumps({"answer": letter}), 0.0),
            3: (200, letter if times > 1 else "hmm, hard to say", 0.0),
            4: (200, wrong, 0.0),
        }[mode]

    def expected(self, record) -> bool | None:
        """Whether the model run gets ``record`` right (None: unanswered)."""
        mode = self.mode(record["prompt"])
        if mode in (10, 11):
            return None
        if mode == 4:
            return False
        return self.letter[record["prompt"]] == record["answer_letter"]


@pytest.fixture
def server(small_ds):
    out, _, _ = small_ds
    script = Script(read_split(out, "test"))

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self):  # noqa: N802
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            status, content, delay = script.reply(body)
            time.sleep(delay)
            payload = {"choices": [{"index": 0, "message": {"role": "assistant", "content": content}}]}
            data = json.dumps(payload if status == 200 else {"error": "boom"}).encode()
            try:
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)
            except (BrokenPipeError, ConnectionResetError):
                pass

        def log_message(self, *args):
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    httpd.daemon_threads = True
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/v1", script
    httpd.shutdown()
    httpd.server_close()


def test_model_evaluation_with_retries_and_unanswered(small_ds, server):
    out, _, _ = small_ds
    url, script = server
    test = read_split(out, "test")
    assert len(test) >= 12
    result = evaluate_dataset(out, url, "scripted", timeout_s=1.0, retries=1, backoff_s=0.01, concurrency=4)
    model, blind = result["rows"]["model"], result["rows"]["model_blind"]
    expected = [script.expected(r) for r in test]
    unanswered = sum(e is None for e in expected)
    assert unanswered >= 2
    assert model["overall"]["unanswered"] == unanswered
    assert model["overall"]["correct"] == sum(e is True for e in expected)
    assert model["overall"]["accuracy"] == pytest.approx(sum(e is True for e in expected) / len(test))
    answered = len(test) - unanswered
    assert model["overall"]["accuracy_answered"] == pytest.approx(sum(e is True for e in expected) / answered)
    assert model["status"].get("failed", 0) >= 1 and model["status"].get("off_format", 0) >= 1
    # the blind run: 'A' for questions with an image, the same replies as before for the others
    blind_expected = [(r["answer_letter"] == "A") if r["image"] else e for r, e in zip(test, expected, strict=True)]
    assert blind["overall"]["unanswered"] == sum(e is None for e in blind_expected)
    assert blind["overall"]["correct"] == sum(e is True for e in blind_expected)
    assert result["client"]["transport_retries"] >= 1 and result["client"]["format_retries"] >= 1
    # per task and category add up
    assert sum(v["total"] for v in model["per_task"].values()) == len(test)
    assert sum(v["total"] for v in model["per_category"].values()) == len(test)
    table = table4_markdown(result)
    assert "| Avg | Object Count | Distance Judgment | Relation Reasoning | Viewpoint Estimation |" in table
    assert "random choice" in table and "majority answer per template" in table and "(blind, no image)" in table


def test_baselines():
    train = [
        {
            "id": "t1",
            "template": "count",
            "answer": "1",
            "choices": ["1", "2"],
            "task": "object_count",
            "category": "x",
        },
        {
            "id": "t2",
            "template": "count",
            "answer": "1",
            "choices": ["1", "3"],
            "task": "object_count",
            "category": "x",
        },
        {
            "id": "t3",
            "template": "count",
            "answer": "2",
            "choices": ["1", "2"],
            "task": "object_count",
            "category": "x",
        },
    ]
    test = [
        {"id": "a", "template": "count", "answer": "1", "choices": ["1", "2", "3", "4"], "task": "object_count"},
        {"id": "b", "template": "count", "answer": "2", "choices": ["2", "3"], "task": "object_count"},
        {"id": "c", "template": "higher", "answer": "x", "choices": ["x", "y"], "task": "relation_reasoning"},
    ]
    for r in test:
        r["category"] = "relative_position"
    rows = baselines(train, test)
    assert rows["random"]["overall"]["correct"] == pytest.approx(0.25 + 0.5 + 0.5)
    # majority of 'count' is '1': right on a, not among b's choices (a guess, 1/2), no majority for 'higher'
    assert rows["majority_per_template"]["overall"]["correct"] == pytest.approx(1.0 + 0.5 + 0.5)
    assert rows["majority_per_template"]["per_task"]["object_count"]["accuracy"] == pytest.approx(0.75)


def test_cli_eval_baselines_and_endpoint_errors(small_ds, tmp_path, capsys):
    out, _, _ = small_ds
    assert main(["vqa", "eval", str(out), "--out", str(tmp_path / "base.json")]) == 0
    printed = capsys.readouterr().out
    assert "random choice" in printed and (tmp_path / "base.md").is_file()
    saved = json.loads((tmp_path / "base.json").read_text())
    assert set(saved["rows"]) == {"random", "majority_per_template"}
    # an endpoint nobody listens on: every question unanswered, the evaluation still finishes
    args = ["vqa", "eval", str(out), "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--no-blind"]
    assert main(args + ["--retries", "0", "--timeout", "0.5", "--limit", "3", "--out", str(tmp_path / "m.json")]) == 0
    saved = json.loads((tmp_path / "m.json").read_text())
    assert saved["rows"]["model"]["overall"]["unanswered"] == 3
    assert saved["rows"]["model"]["status"] == {"failed": 3}
    assert main(["vqa", "eval", str(out), "--endpoint", "http://127.0.0.1:9/v1"]) == 2
    assert main(["vqa", "eval", str(tmp_path / "nothing")]) == 2


def test_missing_images_are_a_clear_error(small_ds, tmp_path, capsys):
    out, _, _ = small_ds
    rows = [r for r in read_split(out, "test") if r["image"]][:2]
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "test.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert main(["vqa", "eval", str(tmp_path / "ds"), "--endpoint", "http://127.0.0.1:9/v1", "--model", "m"]) == 2
    assert "images are missing" in capsys.readouterr().err
