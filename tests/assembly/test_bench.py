"""The assembly benchmark's pieces on the hand-built bedroom (the suite itself runs on synthetic scenes)."""

from __future__ import annotations

from rescene_core.bench.assembly import METRICS, perturb, run_stages, scaling, table
from tests.assembly.helpers import scene


def test_stages_improve_a_perturbed_scene():
    objects, graph, shell = scene()
    start, modes = perturb(objects, graph, shell, seed=3)
    assert set(modes) == {int(i) for i in objects}
    stages = run_stages(objects, start, graph, shell)
    assert list(stages) == ["none", "relations", "repair", "full"]
    full = stages["full"]
    assert full["oob_rate"] == 0.0 and full["collision_pairs"] == 0
    assert full["floor_contact_pass"] == 1.0 and full["support_contact_pass"] == 1.0
    assert full["pose_err_median"] <= stages["none"]["pose_err_median"] + 1e-9


def test_scaling_and_table_render():
    s = scaling(repeats=1)
    assert s["20"] > 0 and s["80"] > 0
    result = {
        "summary": {"x": {st: {k: 0.0 for k in METRICS} for st in ("none", "relations", "repair", "full")}},
        "scaling": s,
        "not_run": {"fused_graph": "why"},
        "seeds": [0],
    }
    assert "scaling" in table(result)
