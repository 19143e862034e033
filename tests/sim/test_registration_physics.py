"""The assembly bench's physics column: the full-stage layout exported with its completions and checked."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.assembly import AssemblyObject
from rescene_core.bench.assembly import METRICS, STAGES, physics_summary, registration_physics, table
from rescene_core.geometry import sim3
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
from tests.fixtures import ONE_WALL_SHELL

pytest.importorskip("mujoco")

SHELL = ONE_WALL_SHELL


def _box(i: int, label: str, extents, centre) -> AssemblyObject:
    box = trimesh.creation.box(extents)
    pose = sim3.sim3_from_parts(1.0, np.eye(3), np.asarray(centre, np.float64))
    return AssemblyObject(InstanceId(i), label, np.asarray(box.vertices), np.asarray(box.faces), pose, exact_shape=True)


def test_the_full_stage_layout_is_exported_and_checked(tmp_path):
    # a cabinet registered 5 cm above the floor and a box registered 3 cm above the cabinet: attachment
    # seats both, so the check finds them stable; without attachment both would fall
    objects = {
        InstanceId(1): _box(1, "cabinet", (0.6, 0.4, 0.8), (0.0, 0.0, 0.45)),
        InstanceId(2): _box(2, "box", (0.2, 0.2, 0.2), (0.0, 0.0, 0.95)),
    }
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 0.9),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1), 0.9),
        )
    )
    out = registration_physics(objects, graph, SHELL, tmp_path / "sim" / "standard_seed0", tmp_path)
    assert out["free"] == 2 and out["stable"] == 2 and out["stable_fraction"] == 1.0, out
    assert out["penetration_t0_max"] < 2e-3 and out["fell_through"] == 0 and out["escaped"] == 0
    assert (tmp_path / "sim/standard_seed0/scene/mjcf/scene.xml").exists()
    assert (tmp_path / "sim/standard_seed0/sim/simcheck.json").exists()
    assert set(out["seconds"]) == {"attach", "export", "simcheck"}


def test_summary_pools_free_objects_and_the_table_shows_it():
    rows = [
        {"physics": {"free": 4, "stable": 4, "stable_fraction": 1.0, "penetration_t0_max": 0.001,
                     "fell_through": 0, "escaped": 0, "seconds": {"attach": 1.0, "export": 2.0, "simcheck": 1.0}}},
        {"physics": {"free": 6, "stable": 3, "stable_fraction": 0.5, "penetration_t0_max": 0.02,
                     "fell_through": 1, "escaped": 0, "seconds": {"attach": 1.0, "export": 4.0, "simcheck": 1.0}}},
    ]  # fmt: skip
    s = physics_summary(rows)
    assert s["stable_fraction"] == pytest.approx(0.7) and s["free"] == 10 and s["fell_through"] == 1
    assert s["penetration_t0_max"] == 0.02 and s["seconds_per_scene"] == pytest.approx(5.0)
    stages = {st: {k: 0.0 for k in METRICS} for st in STAGES}
    result = {
        "summary": {"development": {"seeds": [0, 1], "registration": {**stages, "physics": s}}},
        "scaling": {"20": 0.1, "80": 0.4, "ratio_80_over_20": 4.0},
        "not_run": {},
        "seeds": [0, 1],
    }
    assert "physics (full stage, 2 s): stable 0.700 of 10 free objects" in table(result)
