"""`rescene bench sim` with its exports and checks replaced by fakes: development and held-out seeds are
summarised apart, and the shaken stable fraction stands beside the calm one; ``shake_check`` on a real
exported scene."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rescene_core.bench import sim
from rescene_core.sim import ObjectDrift, SimcheckResult, SimcheckSummary

# stable objects of 10 free ones per (seed, calm or shaken): the development seeds all stable calm, the
# held-out seeds not, so a pooled mean would show 0.75 where the blocks must show 1.0 and 0.5
STABLE = {
    (0, False): 10,
    (1, False): 10,
    (0, True): 9,
    (1, True): 7,
    (100, False): 6,
    (101, False): 4,
    (100, True): 5,
    (101, True): 3,
}


def _check(seed: int, shake: bool) -> SimcheckResult:
    stable = STABLE[(seed, shake)]
    objects = tuple(
        ObjectDrift(f"obj_{i}_lamp", "free", 0.0 if i < stable else 0.05, 0.0, 0.001, i < stable, False, False)
        for i in range(10)
    )
    summary = SimcheckSummary(
        objects=10,
        free=10,
        fixed=0,
        stable=stable,
        stable_fraction=stable / 10,
        fell_through=0,
        escaped=0,
        penetration_t0_max=0.001 * (seed + 1),
        penetration_t0_mean=0.0005,
        drift_max=0.05,
        rotation_max_deg=0.0,
        seconds_simulated=2.0,
        shake=shake,
        seconds=0.1,
    )
    return SimcheckResult(objects, summary)


def _seed_of(run_dir) -> int:
    return int(re.search(r"seed(\d+)$", str(run_dir)).group(1))


@pytest.fixture
def fake_checks(monkeypatch):
    """The exports and the physics checks faked; records every shaken check."""
    shaken: list[str] = []

    def build(preset, seed, work_dir, config):
        return {
            "run_dir": str(work_dir / preset / f"seed{seed}"),
            "objects": 10,
            "export_s": 1.0,
            "pieces_per_object": 4.0,
            "decompose_s_per_object": None,
        }

    def shake_check(run_dir):
        shaken.append(str(run_dir))
        return _check(_seed_of(run_dir), shake=True)

    monkeypatch.setattr(sim, "gt_scene", build)
    monkeypatch.setattr(sim, "pipeline_scene", build)
    monkeypatch.setattr(sim, "simcheck_run", lambda run_dir, config: _check(_seed_of(run_dir), shake=config.shake))
    monkeypatch.setattr(sim, "shake_check", shake_check)
    return shaken


def test_development_and_held_out_seeds_are_summarised_apart_with_the_shake_beside(tmp_path, fake_checks):
    result = sim.run([0, 1], "standard", tmp_path, held_out=[100, 101], shake=True)
    dev, held = result["summary"]["development"], result["summary"]["held_out"]
    assert dev["seeds"] == [0, 1] and held["seeds"] == [100, 101]
    for layout in sim.LAYOUTS:
        assert dev["standard"][layout]["stable_fraction"] == 1.0 and dev["standard"][layout]["free_objects"] == 20
        assert (
            held["standard"][layout]["stable_fraction"] == 0.5
            and held["standard"][layout]["stable_fraction_min"] == 0.4
        )
        assert dev["standard"][layout]["stable_fraction_shake"] == 0.8
        assert dev["standard"][layout]["stable_fraction_shake_min"] == 0.7
        assert held["standard"][layout]["stable_fraction_shake"] == 0.4
        assert held["standard"][layout]["penetration_t0_max"] == pytest.approx(0.102)  # seed 101's, not seed 1's
        assert dev["standard"][layout]["penetration_t0_max"] == pytest.approx(0.002)
    assert len(fake_checks) == 8  # every scene and layout shaken once
    sets = {(s["seed_set"], s["seed"]) for s in result["scenes"]}
    assert sets == {("development", 0), ("development", 1), ("held_out", 100), ("held_out", 101)}
    scene = next(s for s in result["scenes"] if s["seed"] == 101 and s["layout"] == "pipeline")
    assert scene["unstable"] == [f"obj_{i}_lamp" for i in range(4, 10)]
    assert scene["unstable_shake"] == [f"obj_{i}_lamp" for i in range(3, 10)]
    assert scene["shake"]["shake"] is True and scene["simcheck"]["shake"] is False
    json.dumps(result)  # the suite's result is written as JSON

    text = sim.table({"preset": "standard", **result})
    rows = {tuple(line.split()[:3]): line.split() for line in text.splitlines()[2:6]}
    assert rows[("development", "standard", "pipeline")][5:9] == ["1.000", "1.00", "0.800", "0.70"]
    assert rows[("held_out", "standard", "pipeline")][5:9] == ["0.500", "0.40", "0.400", "0.30"]
    assert "development seeds 0-1 (development decisions are made on these)" in text
    assert "held_out seeds 100-101 (reported as they come)" in text
    assert "held_out pipeline standard seed 101: unstable under shake obj_3_lamp" in text


def test_without_shake_or_held_out_seeds_only_the_development_block_is_run(tmp_path, fake_checks):
    result = sim.run([0], "all", tmp_path)
    assert list(result["summary"]) == ["development"] and not fake_checks
    block = result["summary"]["development"]
    assert set(block) == {"seeds", "standard", "cluttered"}
    assert "stable_fraction_shake" not in block["standard"]["gt"]
    assert all("shake" not in s for s in result["scenes"])
    text = sim.table({"preset": "all", **result})
    assert "no held-out seeds (--held-out)" in text and "(not run: --shake)" in text
    row = next(line.split() for line in text.splitlines() if line.startswith("development cluttered gt"))
    assert row[5:9] == ["1.000", "1.00", "-", "-"]


def test_failures_are_counted_in_their_own_seed_set(tmp_path, fake_checks, monkeypatch):
    def failing_pipeline(preset, seed, work_dir, config):
        raise RuntimeError(f"rescene run exited 1 on seed {seed}\ntail")

    monkeypatch.setattr(sim, "pipeline_scene", failing_pipeline)
    result = sim.run([0], "standard", tmp_path, held_out=[100])
    assert result["summary"]["held_out"]["standard"]["pipeline"] == {"scenes": 0, "failed": 1}
    assert result["summary"]["held_out"]["standard"]["gt"]["stable_fraction"] == 0.6
    text = sim.table({"preset": "standard", **result})
    assert "held_out pipeline standard seed 100: ERROR rescene run exited 1 on seed 100" in text
    assert "held_out    standard  pipeline      0   (all 1 failed)" in text


def test_a_seed_in_both_sets_is_refused(tmp_path, fake_checks):
    with pytest.raises(ValueError, match="seeds 3-4 are both development and held-out"):
        sim.run([0, 1, 2, 3, 4], "standard", tmp_path, held_out=[3, 4, 100])


def test_shake_check_shakes_without_replacing_the_calm_check(tmp_path):
    pytest.importorskip("mujoco")
    from rescene_core.export import ExportConfig, ExportObject, export_scene
    from rescene_core.geometry import sim3
    from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
    from rescene_core.sim import SimcheckConfig, simcheck_run
    from tests.fixtures import ONE_WALL_SHELL

    def box(instance: int, extents, centre) -> ExportObject:
        mesh = trimesh.creation.box(extents)
        return ExportObject(instance, "box", mesh.vertices, mesh.faces, sim3.sim3_from_parts(1.0, np.eye(3), centre))

    objects = [box(1, (0.4, 0.4, 0.4), (0.0, 0.0, 0.2005)), box(2, (0.05, 0.05, 0.6), (1.0, 0.0, 0.3005))]
    graph = SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR) for i in (1, 2)))
    export_scene(tmp_path / "scene", objects, ONE_WALL_SHELL, graph, [], ExportConfig())
    calm = simcheck_run(tmp_path, SimcheckConfig())
    shaken = sim.shake_check(Path(tmp_path))
    assert shaken.summary.shake is True and shaken.summary.free == calm.summary.free == 2
    calm_drift = {o.node: o.translation for o in calm.objects}
    shaken_drift = {o.node: o.translation for o in shaken.objects}
    assert max(shaken_drift[n] - calm_drift[n] for n in calm_drift) > 0.005  # the shake moved something
    doc = json.loads((tmp_path / "sim/simcheck.json").read_text())
    assert doc["summary"]["shake"] is False and doc["summary"] == calm.summary.to_json()


def test_newton_column_stands_beside_mujoco_over_the_same_scenes(tmp_path, fake_checks, monkeypatch):
    from rescene_core.sim import newton_check

    def newton_run(run_dir, config):  # Newton: one object fewer stable than MuJoCo per scene, seed 1 fails
        seed = _seed_of(run_dir)
        if seed == 1:
            raise RuntimeError("the Newton simulation diverged")
        record = _check(seed, shake=False).to_json()
        record["summary"]["stable"] -= 1
        differ = {"node": "obj_0_lamp", "stable_mujoco": True, "stable_newton": False, "drift_mujoco": 0.0}
        return record | {"disagreements": [differ | {"drift_newton": 0.03, "reasons": ["mass: MJCF 1, USD 2"]}]}

    monkeypatch.setattr(newton_check, "newton_simcheck_run", newton_run)
    result = sim.run([0, 1], "standard", tmp_path, newton=True)
    block = result["summary"]["development"]["standard"]["pipeline"]
    assert block["stable_fraction_newton"] == 0.9 and block["stable_fraction_mujoco_same"] == 1.0
    assert block["stable_fraction"] == 1.0 and block["newton_failed"] == 1 and block["disagreements"] == 1
    text = sim.table({"preset": "standard", **result})
    row = next(r for r in map(str.split, text.splitlines()) if r[:3] == ["development", "standard", "pipeline"])
    assert row[-3:] == ["0.900", "1.000", "1"]
    assert "seed 1: Newton check ERROR the Newton simulation diverged" in text
    assert "seed 0: obj_0_lamp stable in MuJoCo only (0.0 vs 3.0 cm): mass: MJCF 1, USD 2" in text
