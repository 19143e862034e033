"""Code versions come from the import closure of each stage, found by walking the package's sources."""

from __future__ import annotations

import shutil

import pytest

from rescene_core.records import Stage
from rescene_core.stages.dag import DAG, code_version, code_versions, roots
from rescene_core.stages.version import PACKAGE_ROOT, import_closure, source_hash


@pytest.fixture
def package_copy(tmp_path):
    """A copy of the rescene_core sources whose files a test may edit."""
    root = tmp_path / "rescene_core"
    shutil.copytree(PACKAGE_ROOT, root, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return root


def _versions(root):
    return {s.stage: source_hash(roots(s.stage), root) for s in DAG}


def _append(path, text="\n\ndef _helper_added_by_test():\n    return 1\n"):
    path.write_text(path.read_text() + text)


def test_a_copy_has_the_same_versions_as_the_package(package_copy):
    assert _versions(package_copy) == _versions(PACKAGE_ROOT)


def test_a_helper_only_evaluation_imports_changes_evaluation_alone(package_copy):
    before = _versions(package_copy)
    _append(package_copy / "evaluation" / "structural.py")
    after = _versions(package_copy)
    assert [s for s in before if before[s] != after[s]] == [Stage.EVALUATION]
    assert after[Stage.VIEW] == before[Stage.VIEW]


def test_an_assembly_helper_changes_attachment_and_evaluation_not_view_selection(package_copy):
    """Evaluation's structural metrics import rescene_core.assembly: its version follows that code."""
    assert "rescene_core.assembly.graph" in import_closure(roots(Stage.EVALUATION))
    before = _versions(package_copy)
    _append(package_copy / "assembly" / "graph.py")
    after = _versions(package_copy)
    changed = {s for s in before if before[s] != after[s]}
    assert {Stage.ATTACHMENT, Stage.EVALUATION} <= changed
    assert not changed & {Stage.VIEW, Stage.ASSET, Stage.SHELL, Stage.KEYFRAMES, Stage.RELATIONS}


def test_imports_for_the_type_checker_and_relative_imports(tmp_path):
    pkg = tmp_path / "rescene_core"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from rescene_core import c\n"
        "def f():\n    from .sub import b\n"
    )
    (pkg / "sub" / "__init__.py").write_text("from . import d\n")
    (pkg / "sub" / "b.py").write_text("")
    (pkg / "sub" / "d.py").write_text("import numpy\n")
    (pkg / "c.py").write_text("")
    closure = import_closure(["rescene_core.a"], pkg)
    assert closure == ("rescene_core", "rescene_core.a", "rescene_core.sub", "rescene_core.sub.b", "rescene_core.sub.d")


def test_every_stage_has_a_version():
    assert set(code_versions()) == {s.stage for s in DAG}
    assert len(set(code_versions().values())) == len(DAG)
    assert code_version(Stage.VIEW) == code_version("view")


def test_versions_asked_for_from_many_threads_at_once(package_copy):
    """The flow's task threads ask for their stage's version at the same time on a cold cache."""
    from concurrent.futures import ThreadPoolExecutor

    from rescene_core.stages import version

    version._direct_imports.cache_clear()
    with ThreadPoolExecutor(8) as pool:
        hashes = list(pool.map(lambda s: source_hash(roots(s.stage), package_copy), list(DAG) * 4))
    assert hashes == [source_hash(roots(s.stage), package_copy) for s in list(DAG) * 4]


def test_the_dag_wires_every_input_to_an_earlier_stage():
    """Every body parameter is a run input, a gathered value, its item or an earlier stage's result."""
    from rescene_core.stages.dag import StageSpec, check_dag

    check_dag()

    def needs_a_later_result(run_dir: str, layout: object) -> None: ...

    with pytest.raises(ValueError, match="layout"):
        check_dag((StageSpec(Stage.SHELL, needs_a_later_result, "shell"), *DAG))
