"""Segmentation front ends for captures without instance masks (``rescene import ... --segment geometric``
or ``--segment masks --masks DIR``)."""

from rescene_core.segment.errors import SegmentError
from rescene_core.segment.geometric import SegmentConfig, SegmentResult, segment_geometric
from rescene_core.segment.masks import segment_masks

__all__ = ["SegmentConfig", "SegmentError", "SegmentResult", "segment_geometric", "segment_masks"]
