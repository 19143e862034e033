"""The relation-predictor protocol shared by the backends (``make_predictor`` is in ``predictors``).

A predictor answers a ``Query`` with raw text. The VLM backend sends the prompt and the overlay image
to an endpoint; the geometric backend ignores them and answers from the frame's geometry in the same
JSON format, so every answer goes through the same validator and is recorded the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

from rescene_core.records import RoomShell

if TYPE_CHECKING:
    from rescene_core.capture import Capture
    from rescene_core.scenegraph.view import FrameView


class TransportError(RuntimeError):
    """The endpoint could not be reached or kept failing (after the transport retries). No secrets inside."""


@dataclass(frozen=True)
class Query:
    """One request to a predictor.

    kind: 'relations' (the full per-frame prompt) or 'ab' (a two-option re-ranking prompt).
    image_png: the ID-overlay image, PNG bytes. schema: the JSON schema the answer must follow.
    view, capture, shell: the frame and scene the prompt is about (used by the geometric backend).
    """

    kind: Literal["relations", "ab"]
    system: str
    prompt: str
    image_png: bytes
    schema: dict[str, Any]
    view: FrameView
    capture: Capture
    shell: RoomShell | None


@runtime_checkable
class RelationPredictor(Protocol):
    """A per-frame relation predictor: ``answer`` returns the model's raw text."""

    backend: str
    model: str
    supports_ab: bool
    """Whether A/B re-ranking prompts make sense for this backend (VLMs: yes)."""

    def answer(self, query: Query) -> str: ...
