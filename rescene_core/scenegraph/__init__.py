"""Relation-aware scene graph: per-frame relation inference on key frames and multi-frame fusion.

Public API:
    predict_frame(capture, frame, shell, config, predictor) -> FramePrediction
    predict_frames(capture, frames, shell, config, predictor) -> list[FramePrediction]
    make_predictor(config) -> RelationPredictor ('geometric' or 'openai')
    fuse(predictions, capture, shell, config, missing=set()) -> SceneGraph
    fuse_with_report(...) -> (SceneGraph, FusionReport)
    write_frame / write_graph: the run directory's scenegraph/ files
"""

from rescene_core.scenegraph.backend import Query, RelationPredictor, TransportError
from rescene_core.scenegraph.category import CategoryPrior, load_prior, refit_prior, save_prior
from rescene_core.scenegraph.frame import Attempt, FramePrediction, predict_frame, predict_frames, render_overlay
from rescene_core.scenegraph.fusion import FusionReport, fuse, fuse_with_report
from rescene_core.scenegraph.output import graph_json, write_frame, write_graph
from rescene_core.scenegraph.predictors import make_predictor

__all__ = [
    "Attempt",
    "CategoryPrior",
    "FramePrediction",
    "FusionReport",
    "Query",
    "RelationPredictor",
    "TransportError",
    "fuse",
    "fuse_with_report",
    "graph_json",
    "load_prior",
    "make_predictor",
    "predict_frame",
    "predict_frames",
    "refit_prior",
    "render_overlay",
    "save_prior",
    "write_frame",
    "write_graph",
]
