"""The scale suite (rescene_core/bench/scale.py): its slope, its resident-set sampler and its frame counts
on the command line (its import child: tests/capture/importers/test_scale_import.py, beside the importers'
shared tiny scene; its run child is the whole pipeline, minutes, measured by the suite itself)."""

from __future__ import annotations

import argparse
import time

import numpy as np
import pytest

from flows.cli import parse_frames
from rescene_core.bench import scale


def test_slope_is_the_power_of_the_growth():
    frames = [120, 600, 1200]
    assert scale.slope(frames, [0.01 * f for f in frames]) == pytest.approx(1.0, abs=1e-3)
    assert scale.slope(frames, [1e-4 * f**2 for f in frames]) == pytest.approx(2.0, abs=1e-3)
    assert scale.slope(frames, [3.0, 3.0, 3.0]) == pytest.approx(0.0, abs=1e-3)
    assert scale.slope([120], [1.0]) is None and scale.slope([120, 600], [0.0, 1.0]) is None


def test_the_sampler_sees_an_allocation_inside_its_window():
    with scale._RssSampler() as rss:
        time.sleep(3 * scale.SAMPLE_S)
        start = time.time_ns()
        block = np.ones(100_000_000 // 8)  # 100 MB, touched
        spin = time.process_time() + 0.2
        while time.process_time() < spin:  # CPU time inside the window
            block[::4096] += 1.0
        time.sleep(2 * scale.SAMPLE_S)
        end = time.time_ns()
        del block
    before = rss.peak(0, start)
    during = rss.peak(start, end)
    assert before is not None and during is not None and during - before > 75e6
    cpu = rss.cpu(start, end)
    assert cpu is not None and 0.15 < cpu
    assert rss.cpu(end + 10**9, end + 2 * 10**9) is None  # no samples there


def test_frame_counts_on_the_command_line():
    assert parse_frames("120,600,1200") == [120, 600, 1200]
    for bad in ("120,x", "1", ""):
        with pytest.raises(argparse.ArgumentTypeError, match="--frames"):
            parse_frames(bad)


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/status"), reason="VmHWM is Linux's")
def test_a_child_reports_its_own_peak_not_its_parents():
    # a child started by subprocess (vfork + exec) inherits its parent's ru_maxrss; the suite's children
    # report VmHWM, their own address space's high-water mark
    import subprocess
    import sys

    block = np.ones(300_000_000 // 8)  # 300 MB in this (the parent) process, touched
    probe = (
        "import resource; from rescene_core.bench.scale import peak_rss_self; "
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, peak_rss_self())"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    del block
    inherited, own = (int(x) for x in out.stdout.split())
    assert own < 200e6 < 300e6 <= inherited + 50e6
