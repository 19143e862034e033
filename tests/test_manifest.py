"""The run manifest, the instance table and the run report (rescene_core/manifest.py)."""

from __future__ import annotations

import pyarrow.parquet as pq

from rescene_core.config import RunConfig
from rescene_core.manifest import (
    StageRow,
    build_manifest,
    final_message,
    instance_row,
    render_report,
    stage_counts,
    write_instance_table,
)
from rescene_core.records import InstanceId, Missing, Ref, RefStatus, Stage


def _rows():
    view = Ref("view", "instances/2/view.json", "a" * 64, 2, numbers={"frame": 4})
    gone = Missing(InstanceId(3), Stage.REGISTRATION, "gates rejected")
    rows = [instance_row(2, "chair", view, None), instance_row(3, "desk", None, gone)]
    rows[0] = rows[0].with_asset(Ref("asset", "instances/2/asset.json", "b" * 64, 2, numbers={"faces": 120}))
    return rows, gone


def test_instance_rows_and_table(tmp_path):
    rows, _ = _rows()
    assert rows[0].to_json() == {"instance": 2, "label": "chair", "view": 4, "asset": "120 faces",
                                 "registration": "ok", "missing_stage": "", "missing_reason": ""}  # fmt: skip
    assert rows[1].registration == "missing" and rows[1].missing_stage == "registration"
    missing_view = Ref("view", "v", "c" * 64, 5, RefStatus.MISSING, missing=Missing(InstanceId(5), "view", "x"))
    assert instance_row(5, "lamp", missing_view, missing_view.missing).view == "missing"
    path = write_instance_table(tmp_path / "instances.parquet", rows)
    table = pq.read_table(path)
    assert table.column_names[0] == "instance" and str(table.schema.field("instance").type) == "int64"
    assert table.to_pylist()[0]["view"] == "4" and not list(tmp_path.glob(".*"))  # no temporary file left


def test_final_message_groups_failures_by_stage_and_reason():
    failures = [Missing(InstanceId(7), Stage.ASSET, "boom"), Missing(InstanceId(3), Stage.ASSET, "boom"),
                Missing(InstanceId(5), Stage.REGISTRATION, "timeout")]  # fmt: skip
    message = final_message(failures, ["key frame 4 (timed out)"], "export: disk full")
    assert message == (
        "instances failed: 3, 5, 7 -- asset: boom (3, 7); registration: timeout (5) | "
        "left out of fusion: key frame 4 (timed out) | scene stage failed: export: disk full"
    )
    assert final_message([], [], None) is None


def test_manifest_and_report():
    rows, gone = _rows()
    stage_rows = [
        StageRow(Stage.REGISTRATION, 2, "Completed", False),
        StageRow(Stage.REGISTRATION, 3, "Cached", True),
        StageRow(Stage.EXPORT, None, "Failed", False, message="disk full"),
    ]
    assert stage_counts(stage_rows) == {"registration": {"completed": 1, "cached": 1}, "export": {"failed": 1}}
    capture = Ref("capture", "/data/room.zarr", "d" * 64)
    manifest = build_manifest(
        capture=capture, scene_id="room", config=RunConfig(), flow_run_id="local", started="t0",
        stage_rows=stage_rows, rows=rows, missing=[gone], failed=[], state="Completed", message=None,
        stage_versions={Stage.REGISTRATION: "abc"},
    )  # fmt: skip
    assert manifest["format"] == "rescene-run" and manifest["capture"]["sha256"] == "d" * 64
    assert manifest["code_version"]["stages"] == {"registration": "abc"}
    assert set(manifest["config_hashes"]) == set(RunConfig.model_fields)
    assert manifest["missing"] == [{"instance": 3, "stage": "registration", "reason": "gates rejected"}]
    assert manifest["instances"][1]["missing_reason"] == "gates rejected"
    report = render_report(manifest)
    assert "| registration | 1 | 1 | 0 | 0 |" in report and "- 3 (registration): gates rejected" in report
