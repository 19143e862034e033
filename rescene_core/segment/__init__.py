"""Segmentation front ends for captures without instance masks (``rescene import ... --segment geometric``)."""

from rescene_core.segment.geometric import GeometricConfig, SegmentError, SegmentResult, segment_geometric

__all__ = ["GeometricConfig", "SegmentError", "SegmentResult", "segment_geometric"]
