"""Stage ``validate``: the capture is read and checked whole before any work (every problem listed)."""

from __future__ import annotations

import dataclasses

from rescene_core.capture import open_capture
from rescene_core.records import Ref


def run(capture: Ref) -> Ref:
    """Validate the capture (raises CaptureError listing every problem); its reference with frame and
    instance counts."""
    cap = open_capture(capture.path, validate=True)
    return dataclasses.replace(capture, numbers={"frames": cap.num_frames, "instances": len(cap.instances)})
