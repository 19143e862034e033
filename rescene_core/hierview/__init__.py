"""HierView: per-instance view selection (visibility -> semantic -> 3D completeness) and key frames."""

from rescene_core.hierview.keyframes import KeyFrames, select_keyframes
from rescene_core.hierview.select import frame_stats, select_views
from rescene_core.hierview.semantic import (
    AppearanceScorer,
    ClipScorer,
    ClipUnavailableError,
    NoneScorer,
    SemanticScorer,
    make_scorer,
)

__all__ = [
    "AppearanceScorer",
    "ClipScorer",
    "ClipUnavailableError",
    "KeyFrames",
    "NoneScorer",
    "SemanticScorer",
    "frame_stats",
    "make_scorer",
    "select_keyframes",
    "select_views",
]
