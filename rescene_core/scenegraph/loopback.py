"""A scripted OpenAI-compatible chat endpoint on 127.0.0.1, for tests and the scene-graph benchmark.

It replays answers decided by a ``script`` callable (request JSON -> ``Reply``): a chat answer, an HTTP
error, or a delay (to provoke client timeouts). It is not a model: it stands in for `vllm serve` to
exercise the client, the validation retries and the fusion on bad answers.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

MAX_DELAY_S = 5.0
"""Longest a scripted reply may sleep (keeps timeout tests bounded)."""


@dataclass(frozen=True)
class Reply:
    """What the server sends: ``content`` as a chat answer (status 200), or ``status`` with ``body``."""

    content: str | None = None
    status: int = 200
    body: str = ""
    delay_s: float = 0.0


def chat_completion(content: str, model: str = "scripted") -> dict[str, Any]:
    return {
        "id": "chatcmpl-scripted",
        "object": "chat.completion",
        "model": model,
        "choices": [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": "stop"}],
    }


class LoopbackServer:
    """``with LoopbackServer(script) as server: ... server.base_url ...``; ``requests`` keeps every request."""

    def __init__(self, script: Callable[[dict[str, Any]], Reply]):
        self.script = script
        self.requests: list[dict[str, Any]] = []
        self.headers: list[dict[str, str]] = []
        self._lock = threading.Lock()
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # keep test output quiet
                pass

            def do_POST(self) -> None:  # noqa: N802 (http.server API)
                length = int(self.headers.get("Content-Length", 0))
                try:
                    request = json.loads(self.rfile.read(length) or b"{}")
                except json.JSONDecodeError:
                    request = {}
                with outer._lock:
                    outer.requests.append(request)
                    outer.headers.append(dict(self.headers))
                reply = outer.script(request)
                if reply.delay_s:
                    time.sleep(min(reply.delay_s, MAX_DELAY_S))
                if reply.content is not None:
                    status, payload = 200, json.dumps(chat_completion(reply.content)).encode()
                else:
                    status, payload = reply.status, reply.body.encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(payload)))
                    self.end_headers()
                    self.wfile.write(payload)
                except (BrokenPipeError, ConnectionResetError):
                    pass

        self._server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)

    @property
    def base_url(self) -> str:
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}/v1"

    def __enter__(self) -> LoopbackServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=5)


def user_text(request: dict[str, Any]) -> str:
    """The text part of the request's user message."""
    for message in request.get("messages", []):
        if message.get("role") == "user":
            content = message.get("content")
            if isinstance(content, str):
                return content
            return "".join(part.get("text", "") for part in content if part.get("type") == "text")
    return ""


def image_url(request: dict[str, Any]) -> str:
    """The data URL of the request's image part ('' when none)."""
    for message in request.get("messages", []):
        content = message.get("content")
        if isinstance(content, list):
            for part in content:
                if part.get("type") == "image_url":
                    return str(part["image_url"]["url"])
    return ""
