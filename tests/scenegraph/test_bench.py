from rescene_core.bench.scenegraph import run, table


def test_bench_suite_on_a_tiny_scene(tmp_path):
    result = run([0], "tiny", tmp_path)
    s = result["summary"]
    for variant in ("single_frame", "vote", "full"):
        assert 0.0 <= s[variant]["edge_accuracy"] <= 1.0 and s[variant]["seconds"] > 0
    assert s["full"]["anchor_resolved_ratio"] == 1.0
    assert s["full"]["edge_accuracy"] >= s["vote"]["edge_accuracy"]
    lb = s["loopback_malformed_30"]
    assert lb["graph_valid"] and lb["calls"] >= result["per_seed"][0]["key_frames"]
    # each malformed per-frame answer costs one validation retry, except the last of a frame that fails
    # with its budget spent (no A/B calls on this scene)
    assert result["per_seed"][0]["loopback_malformed_30"]["ab_rechecks"] == 0
    assert lb["validation_retries"] == lb["malformed_answers"] - lb["frames_failed"]
    text = table({**result, "preset": "tiny", "seeds": [0]})
    assert "full" in text and "loopback" in text
