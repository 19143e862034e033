import json

import pytest

from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
from rescene_core.scenegraph.category import SHIPPED_PRIOR, load_prior, refit_prior, save_prior


def test_shipped_prior_is_documented_and_normalised():
    prior = load_prior()
    assert "Hand-authored" in prior.provenance and prior.path == str(SHIPPED_PRIOR)
    assert prior.phi("picture", Relation.MOUNTS_ON, "wall") == 1.0
    assert prior.phi("Sofa", Relation.RESTS_ON, "floor") == 1.0
    assert prior.phi("sofa", Relation.MOUNTS_ON, "wall") == 0.0
    lamp = prior.phi("table lamp", Relation.RESTS_ON, "nightstand")
    assert 0.0 < prior.phi("table lamp", Relation.RESTS_ON, "shelf") < lamp <= 1.0
    for child in prior.counts:
        for rel in (Relation.RESTS_ON, Relation.MOUNTS_ON):
            for parent in ("floor", "wall", "table"):
                assert 0.0 <= prior.phi(child, rel, parent) <= 1.0


def test_unknown_category_uses_the_any_child_row():
    prior = load_prior()
    row, found = prior.row("flux capacitor")
    assert not found and row["rests-on"]["floor"] > 0
    assert prior.phi("flux capacitor", Relation.RESTS_ON, "floor") == 1.0


def test_refit_counts_graph_edges(tmp_path):
    graph = SceneGraph(
        (
            Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR),
            Edge(InstanceId(2), Relation.RESTS_ON, InstanceId(1)),
            Edge(InstanceId(3), Relation.RESTS_ON, InstanceId(1)),
            Edge(InstanceId(4), Relation.MOUNTS_ON, Root.WALL),
        )
    )
    labels = {1: "Desk", 2: "monitor", 3: "monitor", 4: "poster"}
    prior = refit_prior([(graph, labels), (graph, labels)], provenance="test")
    assert prior.counts["monitor"]["rests-on"]["desk"] == 4.0
    assert prior.phi("poster", Relation.MOUNTS_ON, "wall") == 1.0
    path = save_prior(tmp_path / "p.json", prior)
    again = load_prior(path)
    assert again.counts == prior.counts and again.provenance == "test"


def test_bad_prior_files_are_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="prior_path"):
        load_prior(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match="rescene-relation-prior"):
        load_prior(bad)
    bad.write_text(json.dumps({"format": "rescene-relation-prior", "counts": {"x": {"floats-on": {"floor": 1}}}}))
    with pytest.raises(ValueError):
        load_prior(bad)
