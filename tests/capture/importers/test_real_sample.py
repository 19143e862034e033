"""The real RGB-D sample (../shared/data/hololens-000): label-free import, gravity alignment, and the
whole flow on it, every segment placed or an explicit Missing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rescene_core.capture import open_capture
from rescene_core.capture.importers import ImportOptions, import_capture


@pytest.mark.slow
@pytest.mark.timeout(900)  # about a minute on a quiet two-core machine; far longer when it is shared
def test_real_sample_imports_and_the_flow_places_or_reports_every_segment(hololens, prefect_api, tmp_path):
    out = tmp_path / "holo.zarr"
    # every 5th frame keeps the test short; `make demo-real` imports all 75
    report = import_capture("rgbd", hololens, out, ImportOptions(segment="geometric", stride=5))
    cap = open_capture(out)
    al = cap.attrs["alignment"]
    assert al["method"] == "floor" and report["segmenter"] == "geometric"
    assert cap.source == "rgbd+geometric"
    assert report["frames"]["kept"] == 15 and report["throughput_fps"] > 0
    # the floor is at z = 0 within 2 cm and faces +z
    floor_ids = [int(i.id) for i in cap.instances if i.label == "floor"]
    assert floor_ids
    floor = cap.point_cloud(floor_ids[0]).points
    assert abs(float(np.median(floor[:, 2]))) < 0.02
    # every camera stands above the floor, looking roughly level
    assert (cap.world_from_cam[:, 2, 3] > 0.5).all()
    objects = {int(i.id) for i in cap.object_instances}
    assert len(objects) >= 3

    rescene = Path(sys.executable).with_name("rescene")
    run = tmp_path / "run"
    # the run reports to the session's Prefect server instead of starting a temporary one
    env = {**os.environ, "PREFECT_SERVER_ANALYTICS_ENABLED": "false", "PREFECT_API_URL": prefect_api["PREFECT_API_URL"]}
    proc = subprocess.run(
        [str(rescene), "run", str(out), "--out", str(run)], capture_output=True, text=True, env=env, timeout=900
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    layout = json.loads((run / "layout.json").read_text())
    placed = {int(k) for k in layout["objects"]}
    missing = {int(m["instance"]) for m in json.loads((run / "manifest.json").read_text())["missing"]}
    assert placed | missing == objects and not placed & missing
    assert len(placed) >= len(objects) // 2
