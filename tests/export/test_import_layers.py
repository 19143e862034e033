"""The exporter's modules import one another in layers (scene -> simulation -> mjcf/usd -> shell), with
no cycle, counting imports inside functions and under TYPE_CHECKING too."""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

import rescene_core.export

PACKAGE = Path(rescene_core.export.__file__).parent


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("rescene_core.export."):
            out.add(node.module.rsplit(".", 1)[1])
        elif isinstance(node, ast.Import):
            out |= {a.name.rsplit(".", 1)[1] for a in node.names if a.name.startswith("rescene_core.export.")}
    return out


def test_no_import_cycle_among_the_exporters():
    graph = nx.DiGraph()
    for path in PACKAGE.glob("*.py"):
        if path.stem != "__init__":
            graph.add_node(path.stem)
            graph.add_edges_from((path.stem, dep) for dep in _imports(path))
    cycles = [c for c in nx.simple_cycles(graph) if {"scene", "simulation", "mjcf", "usd"} & set(c)]
    assert cycles == []
    assert nx.has_path(graph, "scene", "shell") and not nx.has_path(graph, "shell", "scene")
