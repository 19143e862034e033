"""Segmentation front ends for captures without instance masks (``rescene import ... --segment geometric``)."""

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric import SegmentConfig, SegmentResult, segment_geometric

__all__ = ["SegmentConfig", "SegmentError", "SegmentResult", "segment_geometric"]
