"""Work a stage starts for a later stage while it waits itself, without importing that stage's library.

The export writes the visual scene (scene.json, objects/) and then waits for the collision decomposition's
worker processes; the evaluation, two stages later, reads only the visual scene for its geometry and
rendering metrics. ``visual_scene_written`` lets the export say when those files exist, and the evaluation's
body registers what to start then (``rescene_core/stages/evaluation.py``). A stage that registers nothing
changes nothing, and the export's code version does not take in the evaluation's sources.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

log = logging.getLogger(__name__)

VISUAL_SCENE_WRITTEN: list[Callable[[str, str], None]] = []
"""Called with (run directory, capture path) once the export has written scene.json and objects/, before the
simulation exports; each starts its work in the background and returns at once."""


def visual_scene_written(run_dir: str, capture: str) -> None:
    """Tell every registered callback that the visual scene of ``run_dir`` is written. A callback that raises
    is logged and left out: what it would have started is then computed by its own stage."""
    for callback in VISUAL_SCENE_WRITTEN:
        try:
            callback(run_dir, capture)
        except Exception as err:  # noqa: BLE001 - an early start is an optimisation, never a failure
            log.warning("early start %s for %s failed: %s", getattr(callback, "__name__", callback), run_dir, err)
