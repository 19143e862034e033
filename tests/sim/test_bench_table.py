"""The sim bench's table renders every layout's figures and names unstable objects and failures."""

from rescene_core.bench import SUITES
from rescene_core.bench.sim import table


def test_table_lists_layouts_unstable_objects_and_errors():
    summary = {
        "scenes": 1,
        "failed": 0,
        "free_objects": 10,
        "stable_fraction": 0.9,
        "stable_fraction_min": 0.9,
        "penetration_t0_max": 0.004,
        "penetration_t0_mean": 0.0005,
        "fell_through": 0,
        "escaped": 1,
        "pieces_per_object": 5.5,
        "decompose_s_per_object": None,
        "export_s_per_scene": 3.2,
        "simcheck_s_per_scene": 1.1,
    }
    result = {
        "preset": "standard",
        "seeds": [0],
        "summary": {"development": {"seeds": [0], "standard": {"gt": summary}}},
        "scenes": [
            {"seed_set": "development", "layout": "gt", "preset": "standard", "seed": 0, "unstable": ["obj_3_chair"]},
            {
                "seed_set": "development",
                "layout": "pipeline",
                "preset": "standard",
                "seed": 0,
                "error": "rescene run exited 1\ntail",
            },
        ],
    }
    text = table(result)
    assert "0.900" in text and "4.0mm" in text
    assert "unstable obj_3_chair" in text and "ERROR rescene run exited 1" in text
    assert SUITES["sim"] == "rescene_core.bench.sim"
