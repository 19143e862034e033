"""Perceptual judge (paper Appendix 'GPT-5 Perceptual Judge Protocol'): rendered views of the assembled
scene and the captured key frames go to an OpenAI-compatible chat endpoint with the paper's rubric; the
answer must be strict JSON with an integer score 1-5 and a comment per axis (visual_fidelity,
scene_completeness, aesthetic_quality).

Off unless an endpoint is configured (``JudgeConfig.base_url`` or the environment variable
``RESCENE_JUDGE_BASE_URL``). The transport (timeouts, retries with backoff on 429 / 5xx, the API key only in
the Authorization header) is the scene-graph VLM client's (``scenegraph.openai_backend``). A malformed
answer is sent back with its errors, up to ``retries`` times. An endpoint that is down or keeps failing
gives ``status: failed`` with the reason; it never stops the rest of the evaluation.
"""

from __future__ import annotations

import base64
import io
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import MultiPoint

from rescene_core.config import SceneGraphConfig, VlmClientConfig
from rescene_core.evaluation.rendering import scene_render_meshes
from rescene_core.io import read_json, write_bytes_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Camera
from rescene_core.render import Light, Renderer, Shading
from rescene_core.scenegraph.backend import TransportError
from rescene_core.scenegraph.openai_backend import OpenAIPredictor
from rescene_core.vqa.render import look_at

BASE_URL_ENV = "RESCENE_JUDGE_BASE_URL"
MODEL_ENV = "RESCENE_JUDGE_MODEL"
AXES = ("visual_fidelity", "scene_completeness", "aesthetic_quality")

RUBRIC = """You are an expert evaluator for object-level indoor 3D scene
reconstruction. You will be given one or more rendered images of a
reconstructed scene. Judge only the visible reconstruction quality in
the provided images.

Score the scene on three axes, each from 1 to 5:
1: very poor, 2: poor, 3: acceptable, 4: good, 5: excellent.

Axes:
- visual_fidelity: object geometry, texture/color plausibility,
  lighting consistency, and absence of obvious reconstruction artifacts.
- scene_completeness: whether the main furniture and room elements are
  present and recognizable, with few missing or duplicated objects.
- aesthetic_quality: overall visual coherence, natural arrangement,
  cleanliness of the layout, and plausibility as an indoor scene.

Ignore the image resolution and minor rendering noise. Penalize severe
floating objects, interpenetration, out-of-room objects, broken object
shapes, missing large furniture, and visually incoherent layouts.

Return only valid JSON in the following format:
{
  "visual_fidelity": {"score": <integer 1-5>, "comment": "<short reason>"},
  "scene_completeness": {"score": <integer 1-5>, "comment": "<short reason>"},
  "aesthetic_quality": {"score": <integer 1-5>, "comment": "<short reason>"}
}"""
"""The paper's prompt template, verbatim."""

SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        axis: {
            "type": "object",
            "properties": {"score": {"type": "integer", "minimum": 1, "maximum": 5}, "comment": {"type": "string"}},
            "required": ["score", "comment"],
            "additionalProperties": False,
        }
        for axis in AXES
    },
    "required": list(AXES),
    "additionalProperties": False,
}


class JudgeConfig(BaseModel):
    """Endpoint, images and retries of the perceptual judge."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    base_url: str | None = None
    """OpenAI-compatible base URL (e.g. http://host:8000/v1); RESCENE_JUDGE_BASE_URL when unset; off when neither."""
    model: str = "gpt-5"
    """Model name sent to the endpoint (paper: GPT-5); RESCENE_JUDGE_MODEL overrides the default."""
    api_key_env: str = "RESCENE_JUDGE_API_KEY"
    """Environment variable holding the API key (the key itself is never stored)."""
    api_key: str | None = Field(default=None, repr=False, exclude=True)
    """API key given in code (never written out); else api_key_env."""
    views: int = 4
    """Rendered views of the assembled scene sent to the judge."""
    key_frames: int = 2
    """Captured key frames sent with them, as reference photographs."""
    image_width: int = 512
    """Width of the rendered views (pixels)."""
    image_height: int = 384
    """Height of the rendered views (pixels)."""
    hfov_deg: float = 75.0
    """Horizontal field of view of the rendered views (deg)."""
    retries: int = 2
    """Requests sent again with the errors when an answer is not valid JSON of the schema."""
    timeout_s: float = 120.0
    """Per-request timeout (s)."""
    transport_retries: int = 2
    """Retries with backoff on timeouts, connection errors, 429 and 5xx."""
    backoff_s: float = 1.0
    """First transport-retry delay (s); doubles on each retry."""
    temperature: float = 0.0
    """Sampling temperature."""
    max_tokens: int = 1024
    """Largest answer requested (tokens)."""

    def endpoint(self) -> str | None:
        return self.base_url or os.environ.get(BASE_URL_ENV) or None


@dataclass(frozen=True)
class JudgeRequest:
    """One request: system prompt, text, images (PNG bytes) and the answer's JSON schema."""

    system: str
    prompt: str
    images: tuple[bytes, ...]
    schema: dict[str, Any]
    kind: str = "judge"


def _client(config: JudgeConfig):
    """An ``OpenAIPredictor`` (the scene-graph VLM client) whose requests carry several images."""

    class JudgeClient(OpenAIPredictor):
        def request_body(self, query: JudgeRequest) -> dict[str, Any]:  # type: ignore[override]  # only given JudgeRequests

            parts: list[dict[str, Any]] = [{"type": "text", "text": query.prompt}]
            for png in query.images:
                url = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
                parts.append({"type": "image_url", "image_url": {"url": url}})
            return {
                "model": self.model,
                "messages": [{"role": "system", "content": query.system}, {"role": "user", "content": parts}],
                "response_format": {
                    "type": "json_schema",
                    "json_schema": {"name": "rescene_judge", "schema": query.schema, "strict": True},
                },
                "temperature": config.temperature,
                "max_tokens": config.max_tokens,
            }

    model = os.environ.get(MODEL_ENV) if config.model == JudgeConfig.model_fields["model"].default else None
    sg = SceneGraphConfig(
        backend="openai",
        vlm=VlmClientConfig(
            base_url=config.endpoint(),
            model=model or config.model,
            api_key_env=config.api_key_env,
            api_key=config.api_key,
            timeout_s=config.timeout_s,
            transport_retries=config.transport_retries,
            backoff_s=config.backoff_s,
            temperature=config.temperature,
            max_tokens=config.max_tokens,
            max_concurrency=1,
        ),
    )
    client = JudgeClient(sg)
    client.model = model or config.model
    return client


def parse_answer(text: str) -> tuple[dict[str, Any] | None, list[str]]:
    """(scores, []) for a valid answer, else (None, the errors). Strict: one JSON object, the three axes,
    an integer score 1-5 and a string comment each, nothing else."""
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, TypeError) as err:
        return None, [f"not valid JSON: {err}"]
    if not isinstance(data, dict):
        return None, ["the answer must be a JSON object"]
    errors = [f"unexpected key {k!r}" for k in data if k not in AXES]
    for axis in AXES:
        item = data.get(axis)
        if not isinstance(item, dict):
            errors.append(f"{axis}: missing or not an object")
            continue
        score = item.get("score")
        if isinstance(score, bool) or not isinstance(score, int) or not 1 <= score <= 5:
            errors.append(f"{axis}.score must be an integer 1-5, got {score!r}")
        if not isinstance(item.get("comment"), str):
            errors.append(f"{axis}.comment must be a string")
        errors += [f"{axis}: unexpected key {k!r}" for k in item if k not in ("score", "comment")]
    return (data, []) if not errors else (None, errors)


def _png(rgb: NDArray[np.uint8]) -> bytes:

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def scene_views(
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    capture: Any,
    n: int,
    width: int,
    height: int,
    hfov_deg: float,
) -> list[NDArray[np.uint8]]:
    """``n`` views from inside the room: eyes near the floor polygon's corners (pulled 25% towards the
    centroid) at 1.6 m, looking at the centroid at 0.6 m; ceiling-light shading."""

    if n <= 0 or not placed:
        return []
    floor = shell.get("shell_floor")
    if floor is not None:
        top = float(floor.bounds[1][2])
        xy = np.asarray(floor.vertices)[:, :2]
        # the floor's outline in plan (a 3-D hull of points on one plane is degenerate: its volume divides by 0)
        hull = MultiPoint(xy).convex_hull if len(xy) >= 3 else None
        if hull is None or hull.geom_type != "Polygon":
            corners = np.unique(np.round(xy, 4), axis=0)
        else:
            corners = np.asarray(hull.exterior.coords, np.float64)[:-1]
    else:
        verts = np.concatenate([m.vertices for _, m in placed.values()])
        top = float(verts[:, 2].min())
        lo, hi = verts[:, :2].min(0), verts[:, :2].max(0)
        corners = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
    centre = corners.mean(0)
    angles = np.arctan2(corners[:, 1] - centre[1], corners[:, 0] - centre[0])
    corners = corners[np.argsort(angles)]
    f = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1]])
    renderer = Renderer(
        scene_render_meshes(placed, {k: v for k, v in shell.items()}, capture),
        Shading(lights=(Light((float(centre[0]), float(centre[1]), top + 2.3)),), ambient=0.55),
    )
    pick = np.linspace(0, len(corners), n, endpoint=False).astype(int) % len(corners)
    out = []
    for k in pick:
        eye_xy = corners[k] + 0.25 * (centre - corners[k])
        eye = np.array([eye_xy[0], eye_xy[1], top + 1.6])
        cam = Camera(K, look_at(eye, np.array([centre[0], centre[1], top + 0.6])), width, height)
        out.append(renderer.render(cam).rgb)
    return out


def judge_images(
    run_dir: Path,
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    capture: Any,
    config: JudgeConfig,
) -> tuple[list[str], list[bytes], int]:
    """Render the views and pick the key frames; writes them under RUN/eval/figures/. Returns (relative
    paths, PNG bytes, number of rendered views among them)."""

    names, pngs = [], []
    views = scene_views(placed, shell, capture, config.views, config.image_width, config.image_height, config.hfov_deg)
    for k, rgb in enumerate(views):
        png = _png(rgb)
        name = f"figures/view_{k}.png"
        write_bytes_atomic(RunPaths(run_dir).figures / f"view_{k}.png", png)
        names.append(name)
        pngs.append(png)
    kf = RunPaths(run_dir).keyframes
    frames = [int(t) for t in read_json(kf).get("frames", [])][: config.key_frames] if kf.exists() else []
    for t in frames:
        png = _png(np.asarray(capture.rgb[t]))
        name = f"figures/keyframe_{t}.png"
        write_bytes_atomic(RunPaths(run_dir).figures / f"keyframe_{t}.png", png)
        names.append(name)
        pngs.append(png)
    return names, pngs, len(views)


def judge(pngs: list[bytes], rendered: int, config: JudgeConfig) -> dict[str, Any]:
    """Send the rubric and the images; returns {status: ok | failed, scores, comments, attempts, reason}."""

    client = _client(config)
    legend = f"Images 1-{rendered} are rendered views of the reconstructed scene." + (
        f" Images {rendered + 1}-{len(pngs)} are photographs of the real room, for reference only; "
        "score the rendered views."
        if len(pngs) > rendered
        else ""
    )
    prompt = legend
    errors: list[str] = []
    out: dict[str, Any] = {"model": client.model, "base_url": client.base_url, "attempts": 0, "errors": []}
    try:
        for attempt in range(config.retries + 1):
            out["attempts"] = attempt + 1
            text = client.answer(JudgeRequest(RUBRIC, prompt, tuple(pngs), SCHEMA))
            data, errors = parse_answer(text)
            if data is not None:
                out.update(
                    status="ok",
                    scores={a: int(data[a]["score"]) for a in AXES},
                    comments={a: data[a]["comment"] for a in AXES},
                )
                return out
            out["errors"].append({"attempt": attempt + 1, "errors": errors, "answer": text[:500]})
            prompt = (
                f"{legend}\n\nYour previous answer was not valid: {'; '.join(errors)}.\n"
                f"Previous answer: {text[:500]}\nReturn only valid JSON in the required format."
            )
    except TransportError as err:
        out.update(status="failed", reason=f"endpoint failed: {err}")
        return out
    finally:
        client.close()
    out.update(status="failed", reason=f"no valid answer after {out['attempts']} attempt(s): {'; '.join(errors)}")
    return out


def judge_run(
    run_dir: str | Path,
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    capture: Any,
    config: JudgeConfig | None = None,
) -> dict[str, Any]:
    """The judge of one run: ``status`` 'off' (no endpoint configured), 'ok' or 'failed' (with ``reason``)."""
    config = config or JudgeConfig()
    if not config.endpoint():
        return {"status": "off", "reason": f"no judge endpoint configured (judge.base_url or {BASE_URL_ENV})"}
    if not placed:
        return {"status": "failed", "reason": "the run placed no object to show"}
    names, pngs, rendered = judge_images(Path(run_dir), placed, shell, capture, config)
    out = judge(pngs, rendered, config)
    out["images"] = names
    return out


__all__ = ["AXES", "RUBRIC", "SCHEMA", "JudgeConfig", "judge", "judge_run", "parse_answer", "scene_views"]
