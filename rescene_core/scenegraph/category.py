"""The category prior Phi_k: co-occurrence counts of (child category, relation, parent category).

The table is JSON (``rescene_core/data/relation_prior.json`` ships with the package)::

    {"format": "rescene-relation-prior", "version": 1, "provenance": "...",
     "counts": {"<child category>": {"rests-on": {"floor": 40, "table": 3}, "mounts-on": {"wall": 1}}}}

Parent categories are "floor", "wall" or an object category. Phi = count / (largest count in the child
category's row), so the most frequent support of a category scores 1 and an unseen one 0. A child
category that is not in the table uses the row summed over all categories ("any child").
``refit_prior`` rebuilds a table from scene graphs and their instance labels.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rescene_core.io import write_json_atomic
from rescene_core.records import Relation, Root, SceneGraph

PRIOR_FORMAT = "rescene-relation-prior"
SHIPPED_PRIOR = Path(__file__).resolve().parent.parent / "data" / "relation_prior.json"


def normalize_label(label: str) -> str:
    """Category names are compared lower-case, with '_' and '-' read as spaces."""
    return " ".join(label.lower().replace("_", " ").replace("-", " ").split())


@dataclass(frozen=True)
class CategoryPrior:
    """Counts per child category -> relation -> parent category, and where they come from."""

    counts: dict[str, dict[str, dict[str, float]]]
    provenance: str
    path: str | None = None
    _any: dict[str, dict[str, float]] = field(init=False, repr=False, compare=False)
    """The counts of every child category summed (the row of a category the table does not have)."""

    def __post_init__(self) -> None:
        total: dict[str, dict[str, float]] = {}
        for row in self.counts.values():
            for rel, parents in row.items():
                for p, n in parents.items():
                    total.setdefault(rel, {})
                    total[rel][p] = total[rel].get(p, 0.0) + float(n)
        object.__setattr__(self, "_any", total)

    def row(self, child_label: str) -> tuple[dict[str, dict[str, float]], bool]:
        """The child's counts and whether the category was found (else the any-child row)."""
        key = normalize_label(child_label)
        if key in self.counts:
            return self.counts[key], True
        return self._any, False

    def phi(self, child_label: str, relation: Relation, parent_label: str) -> float:
        """Phi in [0, 1] for (child category, relation, parent category or 'floor'/'wall')."""
        row, _ = self.row(child_label)
        peak = max((n for parents in row.values() for n in parents.values()), default=0.0)
        if peak <= 0:
            return 0.0
        return float(row.get(relation.value, {}).get(normalize_label(parent_label), 0.0)) / peak

    def to_json(self) -> dict[str, Any]:
        return {"format": PRIOR_FORMAT, "version": 1, "provenance": self.provenance, "counts": self.counts}


def load_prior(path: str | Path | None = None) -> CategoryPrior:
    """Read a prior table (``None`` = the shipped one); errors name the file and the problem."""
    path = Path(path) if path is not None else SHIPPED_PRIOR
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"relation prior {path} does not exist; set scenegraph.fusion.prior_path") from None
    except json.JSONDecodeError as err:
        raise ValueError(f"relation prior {path} is not valid JSON: {err}") from None
    if data.get("format") != PRIOR_FORMAT or not isinstance(data.get("counts"), dict):
        raise ValueError(f"relation prior {path}: expected format {PRIOR_FORMAT!r} with a 'counts' mapping")
    counts: dict[str, dict[str, dict[str, float]]] = {}
    for child, row in data["counts"].items():
        for rel, parents in row.items():
            Relation(rel)
            for p, n in parents.items():
                if float(n) < 0:
                    raise ValueError(f"relation prior {path}: negative count for {child}/{rel}/{p}")
                counts.setdefault(normalize_label(child), {}).setdefault(rel, {})[normalize_label(p)] = float(n)
    return CategoryPrior(counts, str(data.get("provenance", "")), str(path))


def refit_prior(
    graphs: Iterable[tuple[SceneGraph, Mapping[int, str]]], provenance: str, base: CategoryPrior | None = None
) -> CategoryPrior:
    """Count (child category, relation, parent category) over scene graphs with their instance labels.

    graphs: (graph, instance id -> category label) pairs. base: counts to add to (None = start empty).
    """
    counts: dict[str, dict[str, dict[str, float]]] = {}
    if base is not None:
        counts = {c: {r: dict(p) for r, p in row.items()} for c, row in base.counts.items()}
    for graph, labels in graphs:
        for e in graph.edges:
            if int(e.child) not in labels:
                continue
            if isinstance(e.parent, Root):
                parent = e.parent.value
            elif int(e.parent) in labels:
                parent = normalize_label(labels[int(e.parent)])
            else:
                continue
            row = counts.setdefault(normalize_label(labels[int(e.child)]), {}).setdefault(e.relation.value, {})
            row[parent] = row.get(parent, 0.0) + 1.0
    return CategoryPrior(counts, provenance)


def save_prior(path: str | Path, prior: CategoryPrior) -> Path:

    return write_json_atomic(path, prior.to_json())
