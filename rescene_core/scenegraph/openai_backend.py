"""The `openai` relation backend: any OpenAI-compatible chat-completions endpoint (e.g. `vllm serve`).

    vllm serve Qwen/Qwen3-VL-32B-Instruct --port 8000        # on a GPU machine
    rescene run CAPTURE --out RUN --set scenegraph.backend=openai \
        --set scenegraph.vlm.base_url=http://gpu-box:8000/v1

The overlay image goes as a base64 ``image_url`` part; the answer is forced to the prompt's JSON schema
with ``response_format={"type": "json_schema", ...}``. Requests time out after ``timeout_s``; at most
``max_concurrency`` are in flight; timeouts, connection errors, HTTP 429 and 5xx are retried
``transport_retries`` times with exponential backoff (``backoff_s``, doubling). Other HTTP errors are not
retried. Invalid answers are not transport errors: the caller's validation retries handle them.

The API key comes from ``config.vlm.api_key`` or the environment variable ``config.vlm.api_key_env``. It is sent
only in the Authorization header and never appears in a log, a record or an exception message.
"""

from __future__ import annotations

import base64
import json
import logging
import os
import threading
import time
from typing import Any

import httpx

from rescene_core.config import SceneGraphConfig, VlmClientConfig
from rescene_core.scenegraph.backend import Query, TransportError

BASE_URL_ENV = "RESCENE_VLM_BASE_URL"
MODEL_ENV = "RESCENE_VLM_MODEL"
DEFAULT_MODEL = VlmClientConfig.model_fields["model"].default
ERROR_BODY_CHARS = 300
"""Characters of an HTTP error body kept in an error message (after redaction)."""

log = logging.getLogger("rescene.scenegraph.openai")


class OpenAIPredictor:
    """Relation predictor talking to an OpenAI-compatible endpoint over HTTP (httpx)."""

    backend = "openai"
    supports_ab = True

    def __init__(self, config: SceneGraphConfig, client: httpx.Client | None = None):
        base_url = config.vlm.base_url or os.environ.get(BASE_URL_ENV)
        if not base_url:
            raise ValueError(
                f"the openai scene-graph backend needs an endpoint: set scenegraph.vlm.base_url or {BASE_URL_ENV} "
                "(for `vllm serve MODEL --port 8000` use http://HOST:8000/v1)"
            )
        self.base_url = base_url.rstrip("/")
        env_model = os.environ.get(MODEL_ENV)
        self.model = env_model if env_model and config.vlm.model == DEFAULT_MODEL else config.vlm.model
        self.config = config
        self._key = config.vlm.api_key or os.environ.get(config.vlm.api_key_env) or None
        headers = {"Content-Type": "application/json"}
        if self._key:
            headers["Authorization"] = f"Bearer {self._key}"
        self._client = client or httpx.Client(headers=headers, timeout=httpx.Timeout(config.vlm.timeout_s))
        self._slots = threading.BoundedSemaphore(max(1, config.vlm.max_concurrency))
        self._lock = threading.Lock()
        self.stats = {"calls": 0, "transport_retries": 0, "transport_failures": 0}

    def __repr__(self) -> str:
        return f"OpenAIPredictor(base_url={self.base_url!r}, model={self.model!r})"

    def close(self) -> None:
        self._client.close()

    def redact(self, text: str) -> str:
        """``text`` with the API key (if any) replaced."""
        return text.replace(self._key, "[redacted]") if self._key else text

    def _count(self, name: str) -> None:
        with self._lock:
            self.stats[name] += 1

    def request_body(self, query: Query) -> dict[str, Any]:
        """The chat-completions request for ``query``."""
        image = base64.b64encode(query.image_png).decode("ascii")
        return {
            "model": self.model,
            "messages": [
                {"role": "system", "content": query.system},
                {
                    "role": "user",
                    "content": [
                        {"type": "text", "text": query.prompt},
                        {"type": "image_url", "image_url": {"url": f"data:image/png;base64,{image}"}},
                    ],
                },
            ],
            "response_format": {
                "type": "json_schema",
                "json_schema": {"name": f"rescene_{query.kind}", "schema": query.schema, "strict": True},
            },
            "temperature": self.config.vlm.temperature,
            "max_tokens": self.config.vlm.max_tokens,
        }

    def answer(self, query: Query) -> str:
        """The model's answer text; raises TransportError after the transport retries are spent."""
        body = self.request_body(query)
        url = f"{self.base_url}/chat/completions"
        problem = "no attempt"
        for attempt in range(self.config.vlm.transport_retries + 1):
            if attempt:
                self._count("transport_retries")
                delay = self.config.vlm.backoff_s * 2 ** (attempt - 1)
                log.warning("retrying %s in %.2fs after: %s", url, delay, problem)
                time.sleep(delay)
            self._count("calls")
            try:
                with self._slots:
                    response = self._client.post(url, json=body)
            except httpx.TimeoutException:
                problem = f"timed out after {self.config.vlm.timeout_s}s"
                continue
            except httpx.TransportError as err:
                problem = self.redact(f"{type(err).__name__}: {err}")
                continue
            if response.status_code == 429 or response.status_code >= 500:
                problem = f"HTTP {response.status_code}: {self.redact(response.text[:ERROR_BODY_CHARS])}"
                continue
            if response.status_code != 200:
                self._count("transport_failures")
                raise TransportError(
                    f"{url} answered HTTP {response.status_code}: {self.redact(response.text[:ERROR_BODY_CHARS])}"
                )
            try:
                content = response.json()["choices"][0]["message"]["content"]
            except (ValueError, KeyError, IndexError, TypeError):
                problem = f"HTTP 200 without a chat completion: {self.redact(response.text[:ERROR_BODY_CHARS])}"
                continue
            return content if isinstance(content, str) else json.dumps(content)
        self._count("transport_failures")
        raise TransportError(
            f"{url}: giving up after {self.config.vlm.transport_retries + 1} attempts; last: {problem}"
        )
