"""`rescene run`, `rescene log` and `rescene eval` end to end (stage doubles, embedded test server)."""

from __future__ import annotations

import json

from flows.cli import main


def test_run_log_eval_commands(prefect_server, fake_stages, box_capture_path, tmp_path, capsys):
    run = tmp_path / "run"
    cfg = tmp_path / "config.yaml"
    cfg.write_text("registration:\n  scale_max: 1.05\n")
    code = main(
        ["run", str(box_capture_path), "--out", str(run), "--config", str(cfg), "--set", "attachment.contact_gap=0.02"]
    )
    assert code == 0
    assert "Completed" in capsys.readouterr().out
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["config"]["registration"]["scale_max"] == 1.05
    assert manifest["config"]["attachment"]["contact_gap"] == 0.02

    assert main(["log", str(run)]) == 0
    out = capsys.readouterr().out
    assert "final state Completed" in out and "/registration/gates" in out

    assert main(["eval", str(run), "--json", str(tmp_path / "m.json")]) == 0
    metrics = json.loads((tmp_path / "m.json").read_text())
    assert metrics["objects"] == 3 and "structural" in metrics and "ground_truth" not in metrics
    assert (run / "eval" / "report.md").exists()


def test_run_rejects_unknown_setting(box_capture_path, tmp_path, capsys):
    assert main(["run", str(box_capture_path), "--out", str(tmp_path / "r"), "--set", "registration.nope=1"]) == 2
    assert "registration has no setting 'nope'" in capsys.readouterr().err


def test_run_bad_capture_exits_2(prefect_server, fake_stages, tmp_path, capsys):
    import zarr

    from tests.flows.fakes import box_capture

    capture = box_capture(tmp_path / "bad.zarr")
    zarr.open_group(str(capture), mode="r+").attrs["format"] = "other"
    assert main(["run", str(capture), "--out", str(tmp_path / "run")]) == 2
    assert "problem(s) in the capture" in capsys.readouterr().err


def test_bench_command_prints_the_table_and_writes_the_result(tmp_path, capsys):
    assert main(["bench", "synth", "--out", str(tmp_path), "--seeds", "0", "--preset", "tiny"]) == 0
    out = capsys.readouterr().out
    result = json.loads((tmp_path / "synth.json").read_text())
    assert result["suite"] == "synth" and result["seeds"] == [0] and "s/frame" in out
    assert f"wrote {tmp_path / 'synth.json'}" in out
    assert main(["bench", "nope", "--out", str(tmp_path)]) == 2
    assert "unknown suite" in capsys.readouterr().err


def test_pipeline_suite_needs_the_harness_the_command_line_gives_it(tmp_path):
    import pytest

    from rescene_core.bench import pipeline

    with pytest.raises(ValueError, match="rescene bench pipeline"):
        pipeline.run([0], "tiny", tmp_path)


def test_run_refused_on_a_changed_capture_or_a_busy_directory_exits_2(
    prefect_server, fake_stages, box_capture_path, tmp_path, capsys
):
    import shutil

    import zarr

    from rescene_core.runlock import hold_run_directory

    run = tmp_path / "run"
    run.mkdir()
    with hold_run_directory(run, flow_run_id="flow-run-elsewhere"):
        assert main(["run", str(box_capture_path), "--out", str(run)]) == 2
    err = capsys.readouterr().err
    assert "is in use by another run" in err and "flow run flow-run-elsewhere" in err
    changed = shutil.copytree(box_capture_path, tmp_path / "changed.zarr")
    rgb = zarr.open_group(str(changed), mode="r+")["frames/rgb"]
    rgb[1] = 255 - rgb[1]
    assert main(["run", str(changed), "--out", str(run)]) == 2
    assert "the capture changed since it was written (files changed: frames/rgb/c/1/0/0/0)" in capsys.readouterr().err
    assert sum(fake_stages.values()) == 0, dict(fake_stages)
