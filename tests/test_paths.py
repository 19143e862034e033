"""RunPaths: the run directory's layout in one object, and docs/run-directory.md lists the same paths."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rescene_core import paths
from rescene_core.paths import RunPaths

DOC = Path(__file__).resolve().parents[1] / "docs" / "run-directory.md"
PLACEHOLDERS = {"{instance}": "<id>", "{frame}": "<t>", "{node}": "<node>", "{name}": "<name>", "{view}": "<view>"}


def _doc_form(template: str) -> str:
    for key, shown in PLACEHOLDERS.items():
        template = template.replace(key, shown)
    return template


def _documented() -> set[str]:
    return set(re.findall(r"^RUN/(\S+)", DOC.read_text(), flags=re.MULTILINE))


def test_every_runpaths_path_is_documented_and_every_documented_path_is_named():
    named = {_doc_form(t) for t in paths.TEMPLATES.values()}
    documented = _documented()
    assert named - documented == set(), "paths of RunPaths missing from docs/run-directory.md"
    assert documented - named == set(), "paths in docs/run-directory.md that RunPaths does not name"


def test_every_template_has_an_accessor_that_gives_it():
    """Each path of the layout is reachable through RunPaths (a property or a method of the item)."""
    run = RunPaths("/runs/r")
    values = {"instance": 7, "frame": 12, "node": "obj_7_chair", "name": "registration-000007", "view": "view_003"}
    reached = set()
    for name in dir(RunPaths):
        if name.startswith("_") or name in ("root", "rel"):
            continue
        attr = getattr(RunPaths, name)
        if isinstance(attr, property):
            reached.add(run.rel(getattr(run, name)))
        elif callable(attr):
            for v in values.values():
                try:
                    reached.add(run.rel(getattr(run, name)(v)))
                except (TypeError, ValueError):
                    continue
    for key, template in paths.TEMPLATES.items():
        expected = template.format(**values).rstrip("/")
        assert expected in reached, f"{key} = {template!r} has no RunPaths accessor"


def test_item_paths_and_relative_form():
    run = RunPaths("/runs/r")
    assert run.pose(7) == Path("/runs/r/instances/7/pose.json")
    assert run.instance_dir(7) == Path("/runs/r/instances/7")
    assert run.frame_png(3) == Path("/runs/r/scenegraph/frames/3.png")
    assert run.scene_mjcf == Path("/runs/r/scene/mjcf/scene.xml")
    assert run.results == Path("/runs/r/.prefect/results")
    assert run.rel(run.asset_glb(12)) == "instances/12/asset.glb"
    with pytest.raises(ValueError):
        run.rel("/elsewhere/x.json")


def test_in_folder_places_a_template_under_a_chosen_folder():
    assert paths.in_folder("/tmp/sg", paths.FRAME_JSON, paths.SCENEGRAPH, frame=3) == Path("/tmp/sg/frames/3.json")
    assert paths.in_folder("/tmp/q", paths.VQA_VIEW, paths.VQA, view="view_001") == Path("/tmp/q/views/view_001.png")
    with pytest.raises(ValueError):
        paths.in_folder("/tmp/q", paths.GRAPH, paths.VQA)
