"""Open3D's random engine, seeded and held by one thread at a time.

Open3D has a single random engine per process (``open3d.utility.random.seed`` seeds it; RANSAC,
``segment_plane`` and the other sampling routines draw from it under Open3D's own mutex), and its
Python bindings release the GIL while RANSAC runs. When several registrations run at the same time in
threads of one process (Prefect's thread task runner maps ``register_instance`` over the instances),
one thread's ``seed`` call lands between another thread's ``seed`` and its draws, and the draws of the
two RANSAC runs interleave: the same asset and target then give different candidates from run to run.
Observed on the synthetic standard seed-0 capture: in one run, restart 0 of an instance returned the
candidate that restart 1 (seed + 1) returns alone, and two restarts of another instance returned the
same candidate.

``seeded_open3d_rng(seed)`` seeds the engine and holds a process-wide lock until the block ends, so a
seeded Open3D call inside it sees the same random stream whatever else runs in other threads, as long
as every other user of the engine in the process takes the same lock. The engine is per process, so a
lock per process is enough (process-based runners have one engine per worker process).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

OPEN3D_RNG_LOCK = threading.RLock()
"""Held while a thread seeds Open3D's random engine and draws from it."""


@contextmanager
def seeded_open3d_rng(seed: int) -> Iterator[int]:
    """Seed Open3D's process-wide random engine with ``seed`` and keep it to this thread for the block.

    Yields the seed (an int in Open3D's C ``int`` range). Other threads entering the same context wait;
    Open3D calls outside it that draw random numbers are not excluded, so every seeded Open3D call in
    the project should go through this context.
    """
    import open3d as o3d

    seed = int(seed)
    if not -(2**31) <= seed < 2**31:
        raise ValueError(f"Open3D seeds are C ints; got {seed}")
    with OPEN3D_RNG_LOCK:
        o3d.utility.random.seed(seed)
        yield seed
