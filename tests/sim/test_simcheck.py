"""The physics check: penetration at t = 0, drift after settling, the stable rule, determinism."""

from __future__ import annotations

import json

import pytest

from rescene_core.export import ExportConfig, export_scene
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
from rescene_core.sim import SimcheckConfig, SimcheckSummary, simcheck_run
from tests.fixtures import ONE_WALL_SHELL, export_box

pytest.importorskip("mujoco")

SHELL = ONE_WALL_SHELL


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    objects = [
        export_box(1, "cabinet", [0.0, 0.0, 0.2005]),  # resting: stable
        export_box(2, "cabinet", [1.0, 0.0, 0.5]),  # floating 0.3 m: falls
        export_box(3, "cabinet", [-1.0, 0.5, 0.19]),  # sunk 1 cm into the floor
    ]
    graph = SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR) for i in (1, 2, 3)))
    export_scene(run / "scene", objects, SHELL, graph, [], ExportConfig(decomposition_cache=str(run / "cache")))
    return run


def test_stable_falling_and_penetrating_objects(run_dir):
    result = simcheck_run(run_dir, SimcheckConfig())
    by_node = {o.node: o for o in result.objects}
    assert by_node["obj_1_cabinet"].stable and by_node["obj_1_cabinet"].penetration_t0 < 1e-3
    falling = by_node["obj_2_cabinet"]
    assert not falling.stable and falling.translation == pytest.approx(0.3, abs=0.02)
    assert by_node["obj_3_cabinet"].penetration_t0 == pytest.approx(0.01, abs=2e-3)
    s = result.summary
    assert s.free == 3 and s.fell_through == 0 and s.escaped == 0
    assert s.penetration_t0_max == pytest.approx(0.01, abs=2e-3)
    doc = json.loads((run_dir / "sim/simcheck.json").read_text())
    assert SimcheckSummary.from_json(doc["summary"]) == s  # the file's summary reads back to the same record
    assert "obj_2_cabinet" in doc["unstable"] and "obj_1_cabinet" not in doc["unstable"]
    assert (run_dir / "sim/before_after.png").stat().st_size > 0


def test_shake_is_deterministic_for_a_seed(run_dir):
    a = simcheck_run(run_dir, SimcheckConfig(shake=True, shake_accel=12.0, seed=3)).to_json()
    b = simcheck_run(run_dir, SimcheckConfig(shake=True, shake_accel=12.0, seed=3)).to_json()
    assert a["objects"] == b["objects"]
    calm = simcheck_run(run_dir, SimcheckConfig()).to_json()
    drift = {o["node"]: o["translation"] for o in a["objects"]}
    calm_drift = {o["node"]: o["translation"] for o in calm["objects"]}
    assert drift["obj_1_cabinet"] > calm_drift["obj_1_cabinet"] + 0.005  # a shake past friction slides it


def test_missing_export_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="export the scene first"):
        simcheck_run(tmp_path)
