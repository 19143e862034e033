"""The user cache (rescene_core/usercache.py) and the CoACD decompositions kept in it: a second run in a
fresh run directory does not decompose again, concurrent writers leave whole entries, the least recently
used entries go over the cap, and a corrupt entry is decomposed and written again."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import trimesh

from rescene_core.usercache import CacheConfigError, UserCache, cache_root, cache_size, content_key, evict

dec_mod = importlib.import_module("rescene_core.colliders.decompose")  # the package exports a function by that name


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    root = tmp_path / "usercache"
    monkeypatch.setenv("RESCENE_CACHE_DIR", str(root))
    monkeypatch.delenv("RESCENE_CACHE_MAX_GB", raising=False)
    return root


def test_root_and_cap_come_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("RESCENE_CACHE_DIR", str(tmp_path / "c"))
    assert cache_root() == tmp_path / "c"
    assert UserCache("convex").directory == tmp_path / "c" / "convex"
    monkeypatch.delenv("RESCENE_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root() == tmp_path / "xdg" / "rescene"
    monkeypatch.setenv("RESCENE_CACHE_MAX_GB", "0.5")
    assert UserCache("convex").max_bytes == 500_000_000
    monkeypatch.setenv("RESCENE_CACHE_MAX_GB", "lots")
    with pytest.raises(CacheConfigError, match="RESCENE_CACHE_MAX_GB is 'lots'.*positive number"):
        UserCache("convex")


def test_keys_separate_their_parts_and_arrays_by_dtype_and_shape():
    a = np.arange(6, dtype=np.float64)
    assert content_key("ab", "c") != content_key("a", "bc")
    assert content_key(a) != content_key(a.reshape(2, 3)) != content_key(a.astype(np.float32))
    assert content_key(a, {"x": 1, "y": 2}) == content_key(a.copy(), {"y": 2, "x": 1})
    with pytest.raises(ValueError, match="hex digest"):
        UserCache("assets").entry("../../etc/passwd")


def test_put_get_and_a_miss(cache_dir):
    cache = UserCache("assets")
    key = content_key("one")
    assert cache.get(key, ".npz") is None
    path = cache.put(key, ".npz", b"payload")
    assert path == cache_dir / "assets" / key[:2] / f"{key}.npz"
    assert cache.get(key, ".npz") == b"payload"
    assert not [p for p in path.parent.iterdir() if p.name.startswith(".")]  # no temporary file left


WRITER = """
import sys
from rescene_core.usercache import UserCache, content_key
worker, keys, size = map(int, sys.argv[1:])
cache = UserCache("convex")
for k in range(keys):
    key = content_key("shared", k)  # every worker writes the same keys with the same content
    cache.put(key, ".bin", bytes([k % 256]) * size)
    cache.put(content_key("own", worker, k), ".bin", bytes([worker]) * size)
    got = cache.get(key, ".bin")
    assert got is None or got == bytes([k % 256]) * size, "a reader saw part of an entry"
"""


def test_concurrent_writers_leave_whole_entries(cache_dir):
    env = os.environ | {"RESCENE_CACHE_DIR": str(cache_dir)}
    procs = [
        subprocess.Popen([sys.executable, "-c", WRITER, str(w), "20", "200000"], env=env, stderr=subprocess.PIPE)
        for w in range(4)
    ]
    errors = [p.communicate(timeout=60)[1].decode() for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0, 0], errors
    cache = UserCache("convex")
    for k in range(20):
        assert cache.get(content_key("shared", k), ".bin") == bytes([k % 256]) * 200_000
        for w in range(4):
            assert cache.get(content_key("own", w, k), ".bin") == bytes([w]) * 200_000
    assert cache_size() == (100, 100 * 200_000)
    assert not [p for p in cache_dir.rglob(".*") if p.is_file()]


def test_the_least_recently_used_entries_go_over_the_cap(cache_dir):
    cache = UserCache("assets", max_bytes=10_000)
    keys = [content_key("entry", k) for k in range(8)]
    now = time.time()
    for k, key in enumerate(keys):  # written an hour apart, oldest first
        path = cache.entry(key, ".bin")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"x" * 2_000)
        os.utime(path, (now - 3600 * (8 - k), now - 3600 * (8 - k)))
    assert cache.get(keys[0], ".bin") is not None  # a hit makes the oldest the most recent
    stale = cache.entry(keys[1], "").parent / ".half-written.tmp"
    stale.write_bytes(b"x")
    os.utime(stale, (now - 7200, now - 7200))
    done = evict(max_bytes=10_000)
    assert done.bytes_left <= 0.8 * 10_000 and done.removed == 4 and done.stale_temps == 1
    left = [k for k, key in enumerate(keys) if cache.entry(key, ".bin").exists()]
    assert left == [0, 5, 6, 7]
    assert evict(max_bytes=10_000).removed == 0  # under the cap: nothing more goes


def test_a_write_over_the_cap_evicts(cache_dir, monkeypatch):
    monkeypatch.setenv("RESCENE_CACHE_MAX_GB", str(5_000 / 1e9))
    cache = UserCache("convex")
    for k in range(10):
        cache.put(content_key(k), ".bin", b"y" * 1_000)
        time.sleep(0.01)  # distinct modification times
    assert cache_size()[1] <= 5_000
    assert cache.get(content_key(9), ".bin") is not None  # the newest stays


def _slanted_ell() -> trimesh.Trimesh:
    """A concave L-shaped slab turned 30 degrees (no exact pieces: it goes to CoACD)."""
    arms = [trimesh.creation.box(bounds=b) for b in ([[0, 0, 0], [1, 0.2, 0.1]], [[0, 0, 0], [0.2, 1, 0.1]])]
    ell = trimesh.boolean.union(arms, engine="manifold")
    ell.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
    return ell


@pytest.fixture
def coacd_calls(monkeypatch):
    calls: list[int] = []
    real = dec_mod._run_coacd

    def counting(vertices, faces, params, timeout):
        calls.append(len(faces))
        return real(vertices, faces, params, timeout)

    monkeypatch.setattr(dec_mod, "_run_coacd", counting)
    return calls


def test_a_second_run_in_a_fresh_run_directory_does_not_run_coacd_again(tmp_path, cache_dir, coacd_calls):
    pytest.importorskip("mujoco")
    from rescene_core.export import ExportConfig, ExportObject, export_scene
    from rescene_core.geometry import sim3
    from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
    from tests.fixtures import CORNER_SHELL

    ell = _slanted_ell()
    obj = ExportObject(1, "desk", ell.vertices, ell.faces, sim3.sim3_from_parts(1.0, np.eye(3), [0.0, 0.0, 0.0]))
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),))
    reports = []
    for run in ("run_a", "run_b"):
        export_scene(tmp_path / run / "scene", [obj], CORNER_SHELL, graph, [], ExportConfig())
        reports.append(json.loads((tmp_path / run / "scene/export_report.json").read_text()))
    assert len(coacd_calls) == 1  # the second run found the first run's decomposition
    assert len(list((cache_dir / "convex").rglob("*.npz"))) == 1
    first, second = (r["objects"][0] for r in reports)
    assert not first["decomposition_cached"] and second["decomposition_cached"]
    mjcf = [(tmp_path / run / "scene" / r["files"]["mjcf"]).read_text() for run, r in zip(("run_a", "run_b"), reports)]
    assert mjcf[0] == mjcf[1]  # the same colliders


def test_a_corrupt_entry_is_decomposed_and_written_again(cache_dir, coacd_calls):
    ell = _slanted_ell()
    settings = dec_mod.DecompositionSettings(max_pieces=4)
    first = dec_mod.decompose(ell.vertices, ell.faces, settings)
    (entry,) = (cache_dir / "convex").rglob("*.npz")
    good = entry.read_bytes()
    entry.write_bytes(good[: len(good) // 3])  # a truncated write, as from a full disk
    again = dec_mod.decompose(ell.vertices, ell.faces, settings)
    assert len(coacd_calls) == 2 and not again.cached
    assert len(again.pieces) == len(first.pieces)
    assert np.allclose(np.concatenate([v for v, _ in again.pieces]), np.concatenate([v for v, _ in first.pieces]))
    assert dec_mod._decode(entry.read_bytes()) is not None  # rewritten whole
    third = dec_mod.decompose(ell.vertices, ell.faces, settings)
    assert third.cached and len(coacd_calls) == 2
