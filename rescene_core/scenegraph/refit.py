"""``rescene prior-refit``: rebuild the category co-occurrence table from a set of scene graphs.

Inputs may be synthetic captures (their ground-truth relations are counted), ``graph.json`` files
written by the scene-graph stage (they carry their node labels), or run directories holding
``scenegraph/graph.json``. Counting the synthetic ground truth used by a benchmark and then evaluating
on the same scenes leaks the answer: refit from scenes you do not evaluate on.
"""

from __future__ import annotations

from pathlib import Path

from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.io import read_json
from rescene_core.paths import RunPaths
from rescene_core.records import SceneGraph
from rescene_core.scenegraph.category import CategoryPrior, load_prior, refit_prior


def graphs_from(path: str | Path) -> tuple[SceneGraph, dict[int, str]]:
    """(graph, instance id -> label) from a capture with ground truth, a graph.json, or a run directory."""
    path = Path(path)
    if path.is_dir() and RunPaths(path).graph.exists():
        path = RunPaths(path).graph
    if path.is_file():
        data = read_json(path)
        if "edges" not in data or "nodes" not in data:
            raise ValueError(f"{path}: not a scene-graph file (needs 'edges' and 'nodes')")
        return SceneGraph.from_json(data), {int(k): str(v) for k, v in data["nodes"].items()}

    capture = open_capture(path)
    gt = read_ground_truth(capture)
    if gt is None:
        raise ValueError(f"{path}: a capture without ground truth; give graph.json files or run directories")
    return gt.graph_by_instance(), {int(i.id): i.label for i in capture.instances}


def refit_from_paths(paths: list[str | Path], add_to: str | Path | None = None) -> CategoryPrior:
    """A prior counted over ``paths`` (added to the table at ``add_to`` when given)."""
    if not paths:
        raise ValueError("give at least one capture, graph.json or run directory")
    base = load_prior(add_to) if add_to is not None else None
    names = ", ".join(Path(p).name for p in paths[:5]) + (" ..." if len(paths) > 5 else "")
    provenance = f"Counted by `rescene prior-refit` over {len(paths)} scene graph(s): {names}"
    if base is not None and add_to is not None:
        provenance += f"; added to {Path(add_to).name} ({base.provenance})"
    return refit_prior((graphs_from(p) for p in paths), provenance, base)
