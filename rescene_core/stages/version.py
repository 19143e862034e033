"""Code versions from the import closure: what a stage's cached results depend on.

A stage's code version hashes the source of every ``rescene_core`` module it imports, directly or through
other modules, found by walking the package's abstract syntax trees (top-level and function-level
imports alike: a helper imported inside a function is code the stage runs; imports under
``if TYPE_CHECKING:`` never run and are left out). Nothing is kept by hand, so
a helper that evaluation imports from ``rescene_core.assembly`` changes evaluation's version, and a
module a stage never reaches changes nothing of it. The walk runs once per process.
"""

from __future__ import annotations

import ast
import hashlib
import threading
from collections.abc import Iterable
from functools import cache
from pathlib import Path

_WALK_LOCK = threading.Lock()
"""One walk at a time: CPython 3.11's ``ast.parse`` is not safe in concurrent threads ("AST constructor
recursion depth mismatch" when the flow's task threads ask for their code versions at once), and the walk
is cached, so the second thread then finds it done."""

PACKAGE = "rescene_core"
PACKAGE_ROOT = Path(__file__).resolve().parents[1]
"""The directory of the ``rescene_core`` package (modules are named relative to its parent)."""


def module_file(module: str, root: Path = PACKAGE_ROOT) -> Path | None:
    """The source file of ``module`` (a package's ``__init__.py``), None when it is not in the package."""
    parts = module.split(".")
    if parts[0] != PACKAGE:
        return None
    base = root.joinpath(*parts[1:])
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return candidate
    return None


def _is_type_checking(node: ast.AST) -> bool:
    """``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``): imports for the type checker only, never run."""
    if not isinstance(node, ast.If):
        return False
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _run_time_nodes(tree: ast.AST) -> Iterable[ast.AST]:
    """Every node of ``tree`` except those under an ``if TYPE_CHECKING:`` block."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        todo.extend(child for child in ast.iter_child_nodes(node) if not _is_type_checking(child))


def _imported_names(tree: ast.AST, module: str, is_package: bool) -> Iterable[str]:
    """Every module name a run-time import of ``tree`` may refer to (``from a import b``: a and a.b)."""
    for node in _run_time_nodes(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = module.split(".")
                anchor = anchor[: len(anchor) - node.level + (1 if is_package else 0)]
                base = ".".join(anchor + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            yield base
            yield from (f"{base}.{alias.name}" for alias in node.names)


def _parents(module: str) -> Iterable[str]:
    """The packages above ``module`` (importing a.b.c runs a/__init__ and a/b/__init__ first)."""
    parts = module.split(".")
    return (".".join(parts[:k]) for k in range(1, len(parts)))


@cache
def _direct_imports(module: str, root: Path = PACKAGE_ROOT) -> frozenset[str]:
    path = module_file(module, root)
    if path is None:
        return frozenset()
    tree = ast.parse(path.read_bytes(), filename=str(path))
    found = set()
    for name in _imported_names(tree, module, path.name == "__init__.py"):
        for candidate in (*_parents(name), name):
            if module_file(candidate, root) is not None:
                found.add(candidate)
    return frozenset(found - {module})


def import_closure(modules: Iterable[str], root: Path = PACKAGE_ROOT) -> tuple[str, ...]:
    """Every package module reachable from ``modules`` by imports (themselves included), sorted."""
    seen: set[str] = set()
    todo = [m for start in modules for m in (*_parents(start), start) if module_file(m, root) is not None]
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        todo.extend(_direct_imports(m, root) - seen)
    return tuple(sorted(seen))


def source_hash(modules: Iterable[str], root: Path = PACKAGE_ROOT) -> str:
    """sha256 (16 hex digits) of the names and sources of the import closure of ``modules``."""
    h = hashlib.sha256()
    with _WALK_LOCK:
        closure = import_closure(modules, root)
    for m in closure:
        path = module_file(m, root)
        assert path is not None  # the closure keeps only modules with a source file
        h.update(m.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]
