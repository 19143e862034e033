"""Writing the run log: one MCAP segment per task, merged into ``logs/run.mcap`` at the end of a run.

Tasks may run in several processes (Dask workers, several Prefect workers), and one MCAP file cannot
be appended to by several writers. So each task writes its own segment ``logs/segments/<name>.mcap``
(atomically: temp file + rename; a re-executed task replaces its segment), and ``merge_segments``
writes every message of every segment, ordered by log time, into one ``logs/run.mcap``.
"""

from __future__ import annotations

import io
import json
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import Writer

from rescene_core import paths
from rescene_core.io import _default, write_bytes_atomic
from rescene_core.runlog.topics import schema_bytes

SEGMENTS_DIR = Path(paths.SEGMENTS)
RUN_LOG = Path(paths.RUN_LOG)
_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def now_ns() -> int:
    return time.time_ns()


@dataclass
class Segment:
    """Messages of one task, buffered in memory and written as one MCAP file by ``close``.

    run_dir: the run directory. name: segment name (one per task and item, e.g. ``registration-0007``).
    """

    run_dir: Path
    name: str
    messages: list[tuple[str, int, bytes]] = field(default_factory=list)

    @property
    def path(self) -> Path:
        return Path(self.run_dir) / SEGMENTS_DIR / f"{_SAFE.sub('_', self.name)}.mcap"

    def log(self, topic: str, payload: dict[str, Any], log_time_ns: int | None = None) -> None:
        """Add one JSON message on ``topic`` (a topic of ``rescene_core.runlog.topics.TOPICS``)."""
        schema_bytes(topic)  # unknown topics fail here, at the call site
        data = json.dumps(payload, default=_default, separators=(",", ":")).encode()
        self.messages.append((topic, now_ns() if log_time_ns is None else int(log_time_ns), data))

    def close(self) -> Path:
        """Write the segment atomically and return its path."""
        write_bytes_atomic(self.path, encode_mcap(self.messages))
        return self.path

    def __enter__(self) -> Segment:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def encode_mcap(messages: list[tuple[str, int, bytes]]) -> bytes:
    """MCAP bytes holding ``messages`` (topic, log time ns, JSON bytes), one channel per topic."""
    buf = io.BytesIO()
    writer = Writer(buf)
    writer.start(profile="", library="rescene")
    channels: dict[str, int] = {}
    schemas: dict[tuple[str, bytes], int] = {}
    for seq, (topic, t, data) in enumerate(sorted(messages, key=lambda m: m[1])):
        if topic not in channels:
            name, body = schema_bytes(topic)
            if (name, body) not in schemas:
                schemas[(name, body)] = writer.register_schema(name=name, encoding="jsonschema", data=body)
            channels[topic] = writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schemas[(name, body)]
            )
        writer.add_message(channel_id=channels[topic], log_time=t, data=data, publish_time=t, sequence=seq)
    writer.finish()
    return buf.getvalue()


def read_messages(path: str | Path, topics: list[str] | None = None) -> list[tuple[str, int, dict[str, Any]]]:
    """(topic, log time ns, decoded JSON) of every message in an MCAP file, in log-time order."""
    out = []
    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(topics=topics, log_time_order=True):
            out.append((channel.topic, int(message.log_time), json.loads(message.data)))
    return out


def merge_segments(run_dir: str | Path) -> Path:
    """Merge every segment under ``RUN/logs/segments`` into ``RUN/logs/run.mcap`` (atomic) and return its path."""
    run_dir = Path(run_dir)
    messages: list[tuple[str, int, bytes]] = []
    for seg in sorted((run_dir / SEGMENTS_DIR).glob("*.mcap")):
        with open(seg, "rb") as f:
            for _schema, channel, message in make_reader(f).iter_messages():
                messages.append((channel.topic, int(message.log_time), bytes(message.data)))
    out = run_dir / RUN_LOG
    write_bytes_atomic(out, encode_mcap(messages))
    return out


def clear_segment(run_dir: str | Path, name: str) -> None:
    """Remove one segment (e.g. before a task re-executes), if present."""
    Segment(Path(run_dir), name).path.unlink(missing_ok=True)


__all__ = ["RUN_LOG", "SEGMENTS_DIR", "Segment", "merge_segments", "read_messages", "now_ns", "encode_mcap"]
