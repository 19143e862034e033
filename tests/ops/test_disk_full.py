"""A disk that fills mid-run, on a small tmpfs: the write that finds no space fails with an error naming the
file, the space free and the fix; nothing half-written is left for a later run to trust; once space is
freed the run resumes, every stage whose cache record was written served from it."""

from __future__ import annotations

import json

import pytest

from rescene_core.io import DiskFullError, atomic_directory, write_bytes_atomic
from tests.ops.helpers import leftover_temporaries, resize_tmpfs, small_tmpfs, trusted_records


def test_atomic_write_on_a_full_disk_keeps_the_old_file(tmp_path):
    with small_tmpfs(tmp_path / "disk", 64) as disk:
        target = write_bytes_atomic(disk / "out" / "pose.json", b'{"old": true}')
        with pytest.raises(DiskFullError, match=r"no space left writing .*pose\.json \(131072 bytes\): \d+ bytes free"):
            write_bytes_atomic(target, b"x" * 131072)
        assert target.read_bytes() == b'{"old": true}'
        with pytest.raises(DiskFullError, match=r"no space left writing .*points\.zarr: \d+ bytes free"):
            with atomic_directory(disk / "out" / "points.zarr") as tmp:
                (tmp / "chunk").write_bytes(b"x" * 131072)
        assert sorted(p.name for p in (disk / "out").iterdir()) == ["pose.json"]  # no temporaries left


@pytest.mark.slow
def test_disk_full_mid_run_then_resume_from_the_cache(prefect_server, fake_stages, box_capture_path, tmp_path):
    from flows.scene import rescene

    # 600 KiB hold the stages up to attachment but not the export's point cloud and report (about 1.9 MiB)
    with small_tmpfs(tmp_path / "disk", 600) as disk:
        run = disk / "run"
        state = rescene(str(box_capture_path), str(run), return_state=True)
        assert state.is_failed()
        assert f"no space left writing {run}/" in state.message and "free space there" in state.message
        trusted, problems = trusted_records(run)
        assert problems == []  # every record a later run would serve points at the file it recorded
        assert trusted["shell"] == 1 and trusted["evaluation"] == 0  # the disk filled mid-run
        assert leftover_temporaries(run) == []
        assert not (run / ".lock").exists()  # the run let go of its directory

        resize_tmpfs(disk, 16 * 1024)  # the operator frees space; the same run again
        fake_stages.clear()
        state = rescene(str(box_capture_path), str(run), return_state=True)
        assert state.is_completed(), state.message
        stages = json.loads((run / "manifest.json").read_text())["stages"]
        for stage, counts in stages.items():  # served from the cache exactly where a record was trusted
            assert counts.get("cached", 0) == trusted[stage], (stage, counts, trusted)
        assert fake_stages["asset"] == 3 - trusted["asset"]
        assert trusted_records(run)[1] == []
