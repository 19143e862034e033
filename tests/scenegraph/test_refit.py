import json

from flows.cli import main
from rescene_core.records import Relation
from rescene_core.scenegraph.category import load_prior


def test_prior_refit_command_from_graph_files(tmp_path, capsys):
    graph = {
        "edges": [
            {"child": 1, "relation": "rests-on", "parent": "floor"},
            {"child": 2, "relation": "rests-on", "parent": 1},
            {"child": 3, "relation": "mounts-on", "parent": "wall"},
        ],
        "nodes": {"1": "desk", "2": "monitor", "3": "clock"},
    }
    run = tmp_path / "run" / "scenegraph"
    run.mkdir(parents=True)
    (run / "graph.json").write_text(json.dumps(graph))
    loose = tmp_path / "g.json"
    loose.write_text(json.dumps(graph))
    out = tmp_path / "prior.json"
    assert main(["prior-refit", str(tmp_path / "run"), str(loose), "--out", str(out)]) == 0
    prior = load_prior(out)
    assert prior.counts["monitor"]["rests-on"]["desk"] == 2.0
    assert prior.phi("clock", Relation.MOUNTS_ON, "wall") == 1.0
    assert "prior-refit" in prior.provenance

    added = tmp_path / "added.json"
    assert main(["prior-refit", str(loose), "--out", str(added), "--add-to", str(out)]) == 0
    assert load_prior(added).counts["monitor"]["rests-on"]["desk"] == 3.0


def test_prior_refit_bad_input_is_exit_2(tmp_path, capsys):
    bad = tmp_path / "x.json"
    bad.write_text("{}")
    assert main(["prior-refit", str(bad), "--out", str(tmp_path / "p.json")]) == 2
    assert "not a scene-graph file" in capsys.readouterr().err
