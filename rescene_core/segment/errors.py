"""The label-free front end's error, shared by the segmenter and the zero-shot labeller."""


class SegmentError(ValueError):
    """The segmentation cannot produce a usable scene (says why and what to change)."""
