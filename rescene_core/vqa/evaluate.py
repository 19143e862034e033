"""Evaluate a vision-language model on a VQA data set (``build_dataset``) through an OpenAI-compatible
endpoint (`vllm serve Qwen/Qwen2.5-VL-7B-Instruct`, or a hosted model), and the baselines that need no model.

    result = evaluate_dataset("DS", endpoint="http://localhost:8000/v1", model="Qwen/Qwen2.5-VL-7B-Instruct")
    print(table4_markdown(result))

Every test question is asked once with its image (``image_url`` part, PNG as base64) and, for the blind
run, once with the text only. The reply is parsed into a choice (``parse_choice``). Transport failures
(time-outs, connection errors, HTTP 429 and 5xx) are retried ``retries`` times with doubling back-off; an
off-format reply is asked again ``retries`` times. A question still without a parsed choice is
*unanswered*: counted in its own column, never silently as wrong (accuracy counts it as not correct and
``accuracy_answered`` leaves it out). Baselines: uniform random choice (its expected accuracy, 1/choices)
and the majority answer of each template on the training split.
"""

from __future__ import annotations

import base64
import json
import re
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rescene_core.vqa.dataset import normalise_answer
from rescene_core.vqa.items import TABLE4_TASKS, Category, TaskType
from rescene_core.vqa.scene import VqaInputError

SYSTEM_PROMPT = (
    "You answer multiple-choice questions about an indoor room seen from an agent's camera. "
    "Reply with the letter of the correct choice."
)
TABLE4_NAMES = {
    TaskType.OBJECT_COUNT: "Object Count",
    TaskType.DISTANCE_JUDGEMENT: "Distance Judgment",
    TaskType.RELATION_REASONING: "Relation Reasoning",
    TaskType.VIEWPOINT_ESTIMATION: "Viewpoint Estimation",
}


class EndpointError(RuntimeError):
    """The endpoint could not be reached or did not answer after the retries."""


def read_split(ds: str | Path, split: str) -> list[dict[str, Any]]:
    """The records of ``DS/<split>.jsonl``; raises ``VqaInputError`` naming the file when it is missing."""
    path = Path(ds) / f"{split}.jsonl"
    if not path.is_file():
        raise VqaInputError(f"{path}: missing; is {ds} a data set written by `rescene vqa build`?")
    rows = []
    for k, line in enumerate(path.read_text().splitlines()):
        if line.strip():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError as err:
                raise VqaInputError(f"{path}, line {k + 1}: not JSON ({err})") from err
    return rows


_LETTER_PATTERNS = (
    r"^\s*\(?([A-Z])\s*[\).:]?\s*$",  # "B", "(B)", "B.", "B)"
    r"^\s*\(?([A-Z])[\).:]\s",  # "B. lamp", "B) lamp"
    r"\banswer\s*(?:is|:)?\s*\(?([A-Z])\b[\).]?",  # "Answer: B", "the answer is (B)"
    r"\boption\s*\(?([A-Z])\b",  # "option B"
    r"^\s*\*\*\(?([A-Z])\b",  # "**B**"
)


def parse_choice(reply: str, choices: list[str] | tuple[str, ...]) -> int | None:
    """The index of the choice a model's reply picks, or None when it picks none or several.

    Understands a JSON object with an ``answer`` field, a bare or decorated letter ('B', '(B)', 'B. lamp',
    'Answer: B', 'option B', '**B**'), and the choice's text (exact after ``normalise_answer``, else the only
    choice whose text occurs in the reply; a longer matching choice wins over one it contains).
    """
    text = str(reply).strip()
    if not text:
        return None
    try:
        obj = json.loads(text)
        if isinstance(obj, dict) and "answer" in obj:
            text = str(obj["answer"]).strip()
    except (json.JSONDecodeError, ValueError):
        pass
    n = len(choices)
    for pattern in _LETTER_PATTERNS:
        m = re.search(pattern, text, flags=re.IGNORECASE if pattern.startswith(r"\b") else 0)
        if m:
            k = ord(m.group(1).upper()) - ord("A")
            if 0 <= k < n:
                return k
    norm = normalise_answer(text)
    exact = [k for k, c in enumerate(choices) if normalise_answer(c) == norm]
    if len(exact) == 1:
        return exact[0]
    low = f" {norm} "
    hits = [k for k, c in enumerate(choices) if f" {normalise_answer(c)} " in low or normalise_answer(c) in norm]
    hits = [
        k
        for k in hits
        if not any(j != k and normalise_answer(choices[k]) in normalise_answer(choices[j]) for j in hits)
    ]
    return hits[0] if len(hits) == 1 else None


@dataclass
class ChatClient:
    """A small OpenAI-compatible chat client (httpx): time-out, retries with doubling back-off."""

    endpoint: str
    model: str
    timeout_s: float = 60.0
    retries: int = 2
    backoff_s: float = 0.5
    max_tokens: int = 32
    api_key: str | None = None

    def __post_init__(self) -> None:
        import httpx

        headers = {"Content-Type": "application/json"}
        if self.api_key:
            headers["Authorization"] = f"Bearer {self.api_key}"
        self._client = httpx.Client(headers=headers, timeout=httpx.Timeout(self.timeout_s))
        self._lock = threading.Lock()
        self.stats = {"calls": 0, "transport_retries": 0, "format_retries": 0}

    def close(self) -> None:
        self._client.close()

    def _count(self, key: str) -> None:
        with self._lock:
            self.stats[key] += 1

    def body(self, prompt: str, image_png: bytes | None) -> dict[str, Any]:
        content: list[dict[str, Any]] = []
        if image_png is not None:
            url = "data:image/png;base64," + base64.b64encode(image_png).decode("ascii")
            content.append({"type": "image_url", "image_url": {"url": url}})
        content.append({"type": "text", "text": prompt})
        return {
            "model": self.model,
            "messages": [{"role": "system", "content": SYSTEM_PROMPT}, {"role": "user", "content": content}],
            "temperature": 0.0,
            "max_tokens": self.max_tokens,
        }

    def complete(self, prompt: str, image_png: bytes | None) -> str:
        """The reply text; raises ``EndpointError`` when the retries are spent."""
        import httpx

        url = self.endpoint.rstrip("/") + "/chat/completions"
        body = self.body(prompt, image_png)
        problem = "no attempt"
        for attempt in range(self.retries + 1):
            if attempt:
                self._count("transport_retries")
                time.sleep(self.backoff_s * 2 ** (attempt - 1))
            self._count("calls")
            try:
                response = self._client.post(url, json=body)
            except httpx.TimeoutException:
                problem = f"timed out after {self.timeout_s}s"
                continue
            except httpx.TransportError as err:
                problem = f"{type(err).__name__}: {err}"
                continue
            if response.status_code == 429 or response.status_code >= 500:
                problem = f"HTTP {response.status_code}"
                continue
            if response.status_code != 200:
                raise EndpointError(f"{url} answered HTTP {response.status_code}: {response.text[:300]}")
            try:
                content = response.json()["choices"][0]["message"]["content"]
            except (ValueError, KeyError, IndexError, TypeError):
                problem = "HTTP 200 without a chat completion"
                continue
            return content if isinstance(content, str) else json.dumps(content)
        raise EndpointError(f"{url}: no answer after {self.retries + 1} attempts; last: {problem}")


def ask(client: ChatClient, record: dict[str, Any], ds: Path, blind: bool) -> dict[str, Any]:
    """Ask one question; returns {"id", "reply", "choice" (index or None), "status"}: status 'answered',
    'off_format' (replies parsed to no choice after the retries) or 'failed' (the endpoint did not answer)."""
    image = None
    if record.get("image") and not blind:
        image = (ds / record["image"]).read_bytes()
    reply = ""
    for attempt in range(client.retries + 1):
        if attempt:
            client._count("format_retries")
        try:
            reply = client.complete(record["prompt"], image)
        except EndpointError as err:
            return {"id": record["id"], "reply": None, "choice": None, "status": "failed", "error": str(err)}
        k = parse_choice(reply, record["choices"])
        if k is not None:
            return {"id": record["id"], "reply": reply, "choice": k, "status": "answered"}
    return {"id": record["id"], "reply": reply, "choice": None, "status": "off_format"}


def score(records: list[dict[str, Any]], picks: Mapping[str, float | None]) -> dict[str, Any]:
    """Accuracy per Table 4 task, per category and overall. ``picks``: record id -> probability that the
    answer is right (1/0 for a model, 1/n for random), or None when unanswered.

    'avg' is over the questions of the four Table 4 tasks; 'overall' over every question."""

    def block(rows: list[dict[str, Any]]) -> dict[str, Any]:
        answered = [p for r in rows if (p := picks.get(r["id"])) is not None]
        correct = float(sum(answered))
        return {
            "total": len(rows),
            "unanswered": len(rows) - len(answered),
            "correct": round(correct, 4),
            "accuracy": correct / len(rows) if rows else None,
            "accuracy_answered": correct / len(answered) if answered else None,
        }

    by_task: dict[str, list] = defaultdict(list)
    by_cat: dict[str, list] = defaultdict(list)
    for r in records:
        by_task[r["task"]].append(r)
        by_cat[r["category"]].append(r)
    table4 = [r for r in records if r["task"] in {t.value for t in TABLE4_TASKS}]
    return {
        "avg": block(table4),
        "overall": block(records),
        "per_task": {t.value: block(by_task.get(t.value, [])) for t in TaskType},
        "per_category": {c.value: block(by_cat.get(c.value, [])) for c in Category},
    }


def baselines(train: list[dict[str, Any]], test: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Random choice (expected accuracy 1/choices) and the majority answer of each template on ``train``
    (when that answer is not among a question's choices, a uniform guess: 1/choices)."""
    random_picks = {r["id"]: 1.0 / len(r["choices"]) for r in test}
    majority: dict[str, str] = {}
    by_template: dict[str, Counter] = defaultdict(Counter)
    for r in train:
        by_template[r["template"]][r["answer"]] += 1
    for template, c in by_template.items():
        majority[template] = sorted(c.items(), key=lambda kv: (-kv[1], kv[0]))[0][0]
    majority_picks = {}
    for r in test:
        guess = majority.get(r["template"])
        majority_picks[r["id"]] = float(guess == r["answer"]) if guess in r["choices"] else 1.0 / len(r["choices"])
    return {"random": score(test, random_picks), "majority_per_template": score(test, majority_picks)}


def evaluate_dataset(
    ds: str | Path,
    endpoint: str | None = None,
    model: str | None = None,
    split: str = "test",
    blind: bool = True,
    concurrency: int = 4,
    timeout_s: float = 60.0,
    retries: int = 2,
    backoff_s: float = 0.5,
    limit: int | None = None,
    api_key: str | None = None,
    progress=None,
) -> dict[str, Any]:
    """Baselines, and with ``endpoint`` and ``model`` the model with images and (``blind``) without.

    Returns {"split", "questions", "rows": {name: score}, "answers": {run: [per-question answers]},
    "client": stats}. ``progress(done, total)`` is called as answers arrive."""
    ds = Path(ds)
    test = read_split(ds, split)
    if limit is not None:
        test = test[:limit]
    missing = [r["image"] for r in test if r.get("image") and not (ds / r["image"]).is_file()]
    if missing:
        raise VqaInputError(
            f"{ds}: {len(missing)} question images are missing, e.g. {ds / missing[0]}; rebuild the data set"
        )
    train = read_split(ds, "train") if (ds / "train.jsonl").is_file() else []
    rows = baselines(train, test)
    answers: dict[str, list[dict[str, Any]]] = {}
    stats: dict[str, int] = {}
    if endpoint:
        if not model:
            raise VqaInputError("--model NAME is needed with --endpoint (the name the server serves)")
        client = ChatClient(endpoint, model, timeout_s=timeout_s, retries=retries, backoff_s=backoff_s, api_key=api_key)
        runs = [("model", False)] + ([("model_blind", True)] if blind else [])
        total = len(test) * len(runs)
        done = 0
        lock = threading.Lock()

        def one(args):
            nonlocal done
            record, is_blind = args
            out = ask(client, record, ds, is_blind)
            with lock:
                done += 1
                if progress is not None:
                    progress(done, total)
            return out

        try:
            with ThreadPoolExecutor(max_workers=max(1, concurrency)) as pool:
                for name, is_blind in runs:
                    got = list(pool.map(one, [(r, is_blind) for r in test]))
                    answers[name] = got
                    picks: dict[str, float | None] = {}
                    for r, a in zip(test, got, strict=True):
                        picks[r["id"]] = (
                            None if a["choice"] is None else float(r["choices"][a["choice"]] == r["answer"])
                        )
                    rows[name] = score(test, picks)
                    rows[name]["status"] = dict(Counter(a["status"] for a in got))
        finally:
            stats = dict(client.stats)
            client.close()
    order = [k for k in ("model", "model_blind", "random", "majority_per_template") if k in rows]
    return {
        "split": split,
        "questions": len(test),
        "model": model,
        "endpoint": endpoint,
        "rows": {k: rows[k] for k in order},
        "answers": answers,
        "client": stats,
    }


def table4_markdown(result: dict[str, Any]) -> str:
    """The paper's Table 4 layout (accuracy per task and 'Avg'), an unanswered column, then per category."""

    def fmt(v: float | None) -> str:
        return "-" if v is None else f"{v:.4f}"

    names = {
        "model": result.get("model") or "model",
        "model_blind": f"{result.get('model') or 'model'} (blind, no image)",
        "random": "random choice",
        "majority_per_template": "majority answer per template",
    }
    head = "| Model | Avg | " + " | ".join(TABLE4_NAMES[t] for t in TABLE4_TASKS) + " | Unanswered |"
    lines = [head, "|---" * (len(TABLE4_TASKS) + 3) + "|"]
    for key, row in result["rows"].items():
        cells = [fmt(row["avg"]["accuracy"])] + [fmt(row["per_task"][t.value]["accuracy"]) for t in TABLE4_TASKS]
        lines.append(f"| {names[key]} | " + " | ".join(cells) + f" | {row['overall']['unanswered']} |")
    cats = [c.value for c in Category]
    lines += ["", "| Model | " + " | ".join(cats) + " | overall |", "|---" * (len(cats) + 2) + "|"]
    for key, row in result["rows"].items():
        cells = [fmt(row["per_category"][c]["accuracy"]) for c in cats] + [fmt(row["overall"]["accuracy"])]
        lines.append(f"| {names[key]} | " + " | ".join(cells) + " |")
    n = {t.value: result["rows"][next(iter(result["rows"]))]["per_task"][t.value]["total"] for t in TaskType}
    lines += [
        "",
        f"{result['questions']} {result['split']} questions; per task: " + ", ".join(f"{k} {v}" for k, v in n.items()),
    ]
    return "\n".join(lines) + "\n"
