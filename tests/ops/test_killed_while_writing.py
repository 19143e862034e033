"""A run killed while writing: kill -9 in the middle of an atomic write leaves the file as it was (a stray
temporary at most, which nothing reads), and a cache record cut short (Prefect writes its records in place,
so a kill there leaves a partial file) is not trusted: that task alone runs again."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from rescene_core.io import hash_file

WRITER = """
import sys
from rescene_core.io import write_bytes_atomic
write_bytes_atomic(sys.argv[1], b"n" * int(sys.argv[2]))
"""


def test_kill_during_an_atomic_write_leaves_the_old_file(tmp_path):
    target = tmp_path / "scene.json"
    target.write_bytes(b'{"old": true}')
    caught = []
    for size in (1 << 28, 1 << 29, 1 << 30):  # larger until the kill lands inside the write
        child = subprocess.Popen([sys.executable, "-c", WRITER, str(target), str(size)])
        deadline = time.monotonic() + 60
        while child.poll() is None and time.monotonic() < deadline:
            temps = list(tmp_path.glob(".scene.json.*"))
            if temps and temps[0].stat().st_size > 0:
                child.send_signal(signal.SIGKILL)
                break
            time.sleep(0.001)
        child.wait(timeout=60)
        assert target.read_bytes() in (b'{"old": true}', b"n" * size)  # never a part of the new bytes
        if child.returncode == -signal.SIGKILL and target.read_bytes() == b'{"old": true}':
            caught += [t.stat().st_size for t in tmp_path.glob(".scene.json.*")]
            break
    assert caught and 0 < caught[0] <= size, "no kill landed inside a write"
    assert target.read_bytes() == b'{"old": true}'


@pytest.mark.slow
def test_cache_record_cut_short_is_recomputed_alone(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import rescene
    from tests.ops.helpers import stage_counts, trusted_records

    run = tmp_path / "run"
    assert rescene(str(box_capture_path), str(run), return_state=True).is_completed()
    records = sorted((run / ".prefect" / "results").glob("asset-*"))
    assert len(records) == 3
    cut = records[0]
    before = hash_file(cut)
    data = cut.read_bytes()
    cut.write_bytes(data[: len(data) // 2])  # what a kill inside Prefect's write of the record leaves
    assert trusted_records(run)[0]["asset"] == 2

    fake_stages.clear()
    assert rescene(str(box_capture_path), str(run), return_state=True).is_completed()
    assert fake_stages["asset"] == 1 and sum(fake_stages.values()) == 1, dict(fake_stages)
    stages = stage_counts(run)
    assert stages["asset"] == {"cached": 2, "completed": 1}
    assert stages["registration"] == {"cached": 3}  # the asset came out the same: its reference too
    assert hash_file(cut) == before and trusted_records(run)[1] == []
