"""eval/report.html: self-contained, and it loads in a real headless Chromium with the 3D viewer showing
the scene, no console errors and no network request."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from flows.cli import main
from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation.geometry import GeometryConfig
from rescene_core.evaluation.rendering import RenderingConfig
from rescene_core.evaluation.report_html import model_viewer_js
from rescene_core.evaluation.run import EvaluationConfig
from tests.evaluation.scene import write_test_capture, write_test_run

CHROMIUM = Path("/usr/bin/chromium")
ARGS = ["--no-sandbox", "--use-gl=swiftshader", "--enable-unsafe-swiftshader", "--disable-background-networking"]
FAST = EvaluationConfig(rendering=RenderingConfig(scale=1.0), geometry=GeometryConfig(fuse_scale=1.0))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = tmp_path_factory.mktemp("report")
    capture = write_test_capture(base / "room.zarr")
    run = write_test_run(base / "run", capture)
    (run / "sim").mkdir()
    (run / "sim" / "simcheck.json").write_text(json.dumps({"stable": True, "max_drift_m": 0.0123, "objects": 2}))
    evaluate_run(run, config=FAST)
    return run


def test_page_is_self_contained(run):
    page = (run / "eval" / "report.html").read_text()
    assert not re.search(r"""(src|href)\s*=\s*['"]?(https?:)?//""", page)
    assert "data:model/gltf-binary;base64," in page
    assert "<model-viewer" in page and "customElements" in page
    assert "max_drift_m" in page and "0.0123" in page  # physics results shown
    assert "Not computed" in page and "no judge endpoint configured" in page


def test_page_without_physics_says_not_run(run, tmp_path):
    import shutil

    other = tmp_path / "run"
    shutil.copytree(run, other, ignore=shutil.ignore_patterns("sim"))
    assert main(["report", str(other), "--evaluate"]) == 0
    page = (other / "eval" / "report.html").read_text()
    assert "Physics check: not run" in page


def test_report_command_rejects_a_missing_run(tmp_path, capsys):
    assert main(["report", str(tmp_path / "nope")]) == 2
    assert "not a run directory" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(
    not CHROMIUM.exists() or model_viewer_js() is None, reason="needs /usr/bin/chromium and npm's model-viewer"
)
def test_page_loads_in_chromium_with_the_model_shown(run):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            page = browser.new_page()
            errors: list[str] = []
            remote: list[str] = []
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on(
                "request", lambda r: None if r.url.startswith(("data:", "file:", "blob:")) else remote.append(r.url)
            )
            page.goto((run / "eval" / "report.html").resolve().as_uri())
            page.wait_for_function(
                "document.querySelector('model-viewer') && document.querySelector('model-viewer').loaded === true",
                timeout=120_000,
            )
            assert page.evaluate("document.querySelector('model-viewer').loaded") is True
            assert page.locator("table").count() >= 4
        finally:
            browser.close()
    assert errors == []
    assert remote == []
