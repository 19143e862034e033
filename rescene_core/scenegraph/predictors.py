"""``make_predictor``: the relation predictor the config names. Imports the backends; they import only
``backend`` (the protocol), so the modules form no cycle."""

from __future__ import annotations

from rescene_core.config import SceneGraphConfig
from rescene_core.scenegraph.backend import RelationPredictor
from rescene_core.scenegraph.geometric import GeometricPredictor
from rescene_core.scenegraph.openai_backend import OpenAIPredictor


def make_predictor(config: SceneGraphConfig) -> RelationPredictor:
    """The predictor chosen by ``config.backend`` ('geometric' or 'openai')."""
    if config.backend == "geometric":
        return GeometricPredictor(config)
    if config.backend == "openai":
        return OpenAIPredictor(config)
    raise ValueError(f"unknown scene-graph backend {config.backend!r}; use 'geometric' or 'openai'")
