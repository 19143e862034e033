import json

from rescene_core.scenegraph.validate import validate_answer

CATS = {1: "table", 2: "table lamp", 3: "picture"}


def answer(*entries):
    return json.dumps({"objects": [dict(zip(("id", "category", "relation", "parent"), e)) for e in entries]})


GOOD = answer((1, "table", "rests-on", "floor"), (2, "table lamp", "rests-on", 1), (3, "picture", "mounts-on", "wall"))


def test_good_answer_is_accepted():
    v = validate_answer(GOOD, CATS, 0.95)
    assert v.ok and not v.errors and v.coverage == 1.0
    assert [e["parent"] for e in v.entries] == ["floor", 1, "wall"]


def test_malformed_json_is_rejected():
    v = validate_answer('{"objects": [{"id": 1,', CATS, 0.95)
    assert not v.ok and "not valid JSON" in v.errors[0] and v.entries == ()
    assert not validate_answer("", CATS, 0.95).ok
    assert not validate_answer('{"things": []}', CATS, 0.95).ok


def test_code_fences_are_tolerated():
    assert validate_answer(f"```json\n{GOOD}\n```", CATS, 0.95).ok


def test_missing_ids_fail_coverage():
    v = validate_answer(answer((1, "table", "rests-on", "floor"), (2, "table lamp", "rests-on", 1)), CATS, 0.95)
    assert not v.ok and any("[3]" in e for e in v.errors)
    assert len(v.entries) == 2 and abs(v.coverage - 2 / 3) < 1e-9


def test_coverage_threshold_allows_a_small_gap():
    cats = {i: "book" for i in range(1, 41)}
    entries = [(i, "book", "rests-on", "floor") for i in range(1, 40)]  # 39/40 = 0.975
    v = validate_answer(answer(*entries), cats, 0.95)
    assert v.ok and v.warnings


def test_duplicate_ids_unknown_ids_bad_relations_and_parents():
    v = validate_answer(
        answer(
            (1, "table", "rests-on", "floor"),
            (1, "table", "rests-on", "wall"),
            (2, "table lamp", "sits-on", 1),
            (3, "picture", "mounts-on", 9),
            (7, "chair", "rests-on", "floor"),
        ),
        CATS,
        0.95,
    )
    text = " ".join(v.errors)
    assert "more than once" in text and "sits-on" in text and "parent 9" in text and "id 7" in text
    assert not v.ok and v.entries == ()


def test_self_loop_and_cycle():
    v = validate_answer(
        answer((1, "table", "rests-on", 1), (2, "table lamp", "rests-on", 3), (3, "picture", "rests-on", 2)), CATS, 0.5
    )
    text = " ".join(v.errors)
    assert "its own parent" in text and "cycle" in text
    assert v.entries == ()


def test_category_change_and_relation_synonym_are_normalised():
    v = validate_answer(
        answer((1, "desk", "rests_on", "floor"), (2, "table lamp", "support", 1), (3, "picture", "mounts-on", "Wall")),
        CATS,
        0.95,
    )
    assert v.ok
    assert (
        v.entries[0]["category"] == "table"
        and v.entries[1]["relation"] == "rests-on"
        and v.entries[2]["parent"] == "wall"
    )
    assert any("replaced" in w for w in v.warnings)
