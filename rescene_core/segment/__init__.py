"""Segmentation front ends for captures without instance masks (``rescene import ... --segment geometric``)."""

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric import GeometricConfig, SegmentResult, segment_geometric

__all__ = ["GeometricConfig", "SegmentError", "SegmentResult", "segment_geometric"]
