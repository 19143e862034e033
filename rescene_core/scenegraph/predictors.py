"""``make_predictor``: the relation predictor the config names. Imports the backends; they import only
``backend`` (the protocol), so the modules form no cycle."""

from __future__ import annotations

import functools

from rescene_core.config import SceneGraphConfig
from rescene_core.scenegraph.backend import RelationPredictor
from rescene_core.scenegraph.geometric import GeometricPredictor
from rescene_core.scenegraph.openai_backend import OpenAIPredictor


def make_predictor(config: SceneGraphConfig) -> RelationPredictor:
    """The predictor chosen by ``config.backend`` ('geometric' or 'openai'), built once per process and
    config: every key frame, task and flow run of a worker shares it (and the VLM client's connection
    pool and its ``vlm.max_concurrency`` slots).

    The cache key is the config's JSON plus the API key given in code: the key is excluded from every dump
    (so it never reaches a file or a hash), so the JSON alone would rebuild the client without it and
    would let configs that differ only in their key share one client."""
    return _predictor(config.model_dump_json(), config.vlm.api_key)


@functools.lru_cache(maxsize=8)
def _predictor(config_json: str, api_key: str | None) -> RelationPredictor:
    config = SceneGraphConfig.model_validate_json(config_json)
    config = config.model_copy(update={"vlm": config.vlm.model_copy(update={"api_key": api_key})})
    if config.backend == "geometric":
        return GeometricPredictor(config)
    if config.backend == "openai":
        return OpenAIPredictor(config)
    raise ValueError(f"unknown scene-graph backend {config.backend!r}; use 'geometric' or 'openai'")
