"""Development and held-out seed sets: ``seed_sets``, ``format_seeds``, and ``rescene bench --held-out``."""

from __future__ import annotations

import json

import pytest

from flows.cli import main
from rescene_core.bench import SEED_SETS, format_seeds, seed_sets, sim


def test_seed_sets_keep_the_held_out_seeds_apart():
    assert seed_sets([0, 1, 2, 3, 4], [100, 101]) == {"development": [0, 1, 2, 3, 4], "held_out": [100, 101]}
    assert seed_sets([0, 1], None) == {"development": [0, 1]}
    assert tuple(seed_sets([0], [7])) == SEED_SETS
    with pytest.raises(ValueError, match="seeds 1 are both"):
        seed_sets([0, 1], [1, 100])


def test_format_seeds_writes_what_seeds_reads():
    assert format_seeds([0, 1, 2, 3, 4]) == "0-4"
    assert format_seeds([3, 7, 8, 9]) == "3,7-9"
    assert format_seeds([100]) == "100"
    assert format_seeds([]) == ""


def test_bench_passes_held_out_seeds_and_shake_to_the_sim_suite(tmp_path, capsys, monkeypatch):
    calls = []

    def fake_run(seeds, preset, work_dir, held_out=None, shake=False):
        calls.append((seeds, preset, held_out, shake))
        blocks = {"development": {"seeds": seeds}, **({"held_out": {"seeds": held_out}} if held_out else {})}
        return {"summary": blocks, "scenes": []}

    monkeypatch.setattr(sim, "run", fake_run)
    argv = ["bench", "sim", "--out", str(tmp_path), "--seeds", "0-1", "--held-out", "100-102", "--shake"]
    assert main(argv) == 0
    assert calls == [([0, 1], "standard", [100, 101, 102], True)]
    result = json.loads((tmp_path / "sim.json").read_text())
    assert result["seeds"] == [0, 1] and result["held_out"] == [100, 101, 102]
    out = capsys.readouterr().out
    assert "development seeds 0-1" in out and "held_out seeds 100-102" in out

    assert main(["bench", "sim", "--out", str(tmp_path / "plain"), "--seeds", "0"]) == 0
    assert calls[-1] == ([0], "standard", None, False)
    assert "held_out" not in json.loads((tmp_path / "plain/sim.json").read_text())


def test_a_suite_without_held_out_seeds_refuses_them_before_running(tmp_path, capsys):
    assert main(["bench", "synth", "--out", str(tmp_path), "--held-out", "100-101", "--preset", "tiny"]) == 2
    assert "the synth suite does not take held_out" in capsys.readouterr().err
    assert main(["bench", "assembly", "--out", str(tmp_path), "--shake"]) == 2
    assert "the assembly suite does not take shake" in capsys.readouterr().err
    assert not (tmp_path / "synth.json").exists() and not (tmp_path / "assembly.json").exists()
