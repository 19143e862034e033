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
    pool and its ``vlm.max_concurrency`` slots)."""
    return _predictor(config.model_dump_json())


@functools.lru_cache(maxsize=8)
def _predictor(config_json: str) -> RelationPredictor:
    config = SceneGraphConfig.model_validate_json(config_json)
    if config.backend == "geometric":
        return GeometricPredictor(config)
    if config.backend == "openai":
        return OpenAIPredictor(config)
    raise ValueError(f"unknown scene-graph backend {config.backend!r}; use 'geometric' or 'openai'")
