"""Captures: the on-disk format, its validation, and generators/importers that produce it."""

from rescene_core.capture.format import Capture, CaptureArrays, points_to_csr, write_capture
from rescene_core.capture.validate import CaptureError, Problem, check_capture, open_capture

__all__ = [
    "Capture",
    "CaptureArrays",
    "CaptureError",
    "Problem",
    "check_capture",
    "open_capture",
    "points_to_csr",
    "write_capture",
]
