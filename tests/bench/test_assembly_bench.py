"""`rescene bench assembly` on development and held-out seeds: the hand-built bedroom stands in for the
synthetic layouts and a fake for the pipeline's registration start, so no pipeline runs; each seed set is
summarised on its own."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rescene_core.bench import assembly
from rescene_core.bench.assembly import METRICS, STAGES
from tests.assembly.helpers import scene

FREE = 10
STABLE = {0: 10, 1: 10, 100: 6, 101: 4}
"""Stable objects of the registration start's physics check per seed: a pooled figure would be 0.75."""


def _registration_scene(seed, work_dir, preset="standard"):
    if seed == 102:
        raise RuntimeError("rescene run exited 1")
    stages = {st: {**{k: seed / 1000 for k in METRICS}, "pose_err_mean": seed / 1000} for st in STAGES}
    physics = {
        "free": FREE,
        "stable": STABLE[seed],
        "stable_fraction": STABLE[seed] / FREE,
        "penetration_t0_max": 0.001,
        "fell_through": 0,
        "escaped": 0,
        "seconds": {"attach": 1.0, "export": 1.0, "simcheck": 1.0},
    }
    graphs = {g: stages for g in assembly.REGISTRATION_GRAPHS}
    return {"preset": preset, "seed": seed, "graphs": graphs, "exact_shapes": graphs, "physics": physics}


@pytest.fixture
def plans(monkeypatch):
    drawn: list[str] = []
    monkeypatch.setattr(assembly, "ground_truth_layout", lambda preset, seed: (*scene(), "bedroom"))
    monkeypatch.setattr(assembly, "registration_scene", _registration_scene)
    monkeypatch.setattr(assembly, "draw_plan", lambda path, *args: drawn.append(path.name))
    monkeypatch.setattr(assembly, "scaling", lambda: {"20": 0.1, "80": 0.3, "ratio_80_over_20": 3.0})
    return drawn


def test_development_and_held_out_seeds_are_summarised_apart(tmp_path, plans):
    result = assembly.run([0, 1], "standard", tmp_path, held_out=[100, 101, 102])
    dev, held = result["summary"]["development"], result["summary"]["held_out"]
    assert dev["seeds"] == [0, 1] and held["seeds"] == [100, 101, 102]
    assert set(dev) == set(held) == {"seeds", "standard", "cluttered", *assembly_keys()}
    # gt-perturbed start: each block is the mean of its own scenes (the perturbation is seeded per scene)
    for seed_set, block in result["summary"].items():
        rows = [s for s in result["scenes"] if s["seed_set"] == seed_set and s["preset"] == "standard"]
        assert sorted(r["seed"] for r in rows) == block["seeds"]
        for stage in STAGES:
            want = np.mean([r["stages"][stage]["pose_err_median"] for r in rows])
            assert block["standard"][stage]["pose_err_median"] == pytest.approx(want)
    assert dev["standard"]["none"]["pose_err_median"] != held["standard"]["none"]["pose_err_median"]
    # registration start: seed 102 failed and is reported, not pooled; the physics line per set
    assert dev["registration"]["none"]["oob_rate"] == pytest.approx(0.0005)
    assert held["registration"]["none"]["oob_rate"] == pytest.approx(0.1005)
    assert dev["registration"]["physics"]["stable_fraction"] == 1.0
    assert held["registration"]["physics"]["stable_fraction"] == 0.5
    assert held["registration"]["physics"]["per_scene"] == [0.6, 0.4]
    assert result["not_run"] == {"registration_standard_seed102": "RuntimeError: rescene run exited 1"}
    assert {(r["seed_set"], r["seed"]) for r in result["registration_scenes"]} == {
        ("development", 0),
        ("development", 1),
        ("held_out", 100),
        ("held_out", 101),
    }
    assert sorted(plans) == ["cluttered_0.png", "cluttered_100.png", "standard_0.png", "standard_100.png"]
    json.dumps(result)  # the suite's result is written as JSON

    text = assembly.table(result)
    dev_text, held_text = text.split("== held_out seeds 100-102 (reported as they come)")
    assert dev_text.startswith("== development seeds 0-1 (development decisions are made on these)")
    assert "physics (full stage, 2 s): stable 1.000 of 20 free objects (per scene [1.0, 1.0])" in dev_text
    assert "physics (full stage, 2 s): stable 0.500 of 20 free objects (per scene [0.6, 0.4])" in held_text
    assert "registration (registration start, generated assets, fused graph, mean over held_out seeds 100-102)" in (
        held_text
    )
    assert "registration_standard_seed102: RuntimeError" in held_text
    overview = {
        tuple(line.split()[:2]): line.split()[2:] for line in text.split("full stage by seed set")[1].splitlines()
    }
    assert overview[("registration", "development")][-1] == "1.000"
    assert overview[("registration", "held_out")] == [*["0.1005"] * 6, "0.500"]
    assert overview[("standard", "held_out")][-1] == "-"  # the gt-perturbed start has no physics check


def test_without_held_out_seeds_only_the_development_block_is_run(tmp_path, plans):
    result = assembly.run([0], "standard", tmp_path)
    assert list(result["summary"]) == ["development"]
    assert all(s["seed_set"] == "development" for s in result["scenes"] + result["registration_scenes"])
    text = assembly.table(result)
    assert text.startswith("no held-out seeds (--held-out)\n== development seeds 0 ")


def test_a_seed_in_both_sets_is_refused(tmp_path, plans):
    with pytest.raises(ValueError, match="both development and held-out"):
        assembly.run([0, 1], "standard", tmp_path, held_out=[1])
    assert not plans


def assembly_keys() -> set[str]:
    """The registration start's summary keys of the standard preset."""
    return {
        assembly.registration_key("standard", graph, shapes)
        for graph in assembly.REGISTRATION_GRAPHS
        for shapes in assembly.REGISTRATION_SHAPES
    }
