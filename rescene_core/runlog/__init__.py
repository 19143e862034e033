"""The run log (``RUN/logs/run.mcap``): JSON-schema MCAP channels for every stage's decisions, plus
``foxglove.SceneUpdate`` snapshots, written as one segment per task and merged at the end of a run."""

from rescene_core.runlog.foxglove import SceneObject, scene_update
from rescene_core.runlog.topics import TOPICS
from rescene_core.runlog.writer import RUN_LOG, SEGMENTS_DIR, Segment, merge_segments, now_ns, read_messages

__all__ = [
    "RUN_LOG",
    "SEGMENTS_DIR",
    "TOPICS",
    "SceneObject",
    "Segment",
    "merge_segments",
    "now_ns",
    "read_messages",
    "scene_update",
]
