"""Validation of one frame's answer: JSON, id coverage, duplicates, relations, parents, self loops, cycles.

Errors send the answer back to the model (retry prompt); warnings are recorded only. The entries that
pass every per-entry check are returned even when the answer as a whole fails, so that the caller can
use a partial answer after the retry budget is spent.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import networkx as nx

from rescene_core.scenegraph.prompt import RELATIONS, ROOTS

RELATION_SYNONYMS = {
    "rests-on": "rests-on",
    "rests_on": "rests-on",
    "rests on": "rests-on",
    "restson": "rests-on",
    "support": "rests-on",
    "supported-by": "rests-on",
    "mounts-on": "mounts-on",
    "mounts_on": "mounts-on",
    "mounts on": "mounts-on",
    "mountson": "mounts-on",
    "attachment": "mounts-on",
    "attached-to": "mounts-on",
}
"""Relation spellings normalised to the two classes (support, attachment); anything else is an error."""


@dataclass(frozen=True)
class Validation:
    """Outcome of validating one answer.

    entries: accepted entries {"id", "category", "relation", "parent"} in display ids.
    coverage: fraction of the visible display ids with an accepted entry.
    """

    ok: bool
    errors: tuple[str, ...]
    warnings: tuple[str, ...]
    entries: tuple[dict[str, Any], ...]
    coverage: float

    def to_json(self) -> dict[str, Any]:
        return {
            "ok": self.ok,
            "errors": list(self.errors),
            "warnings": list(self.warnings),
            "entries": list(self.entries),
            "coverage": self.coverage,
        }


@dataclass
class _State:
    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _as_int(value: Any) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def _strip_fences(text: str) -> str:
    t = text.strip()
    if t.startswith("```"):
        t = t.split("\n", 1)[1] if "\n" in t else t[3:]
        if t.rstrip().endswith("```"):
            t = t.rstrip()[:-3]
    return t.strip()


def validate_answer(text: str | None, categories: dict[int, str], min_coverage: float) -> Validation:
    """Check an answer against the frame's visible display ids and their fixed categories."""
    st = _State()
    visible = set(categories)
    if text is None or not text.strip():
        return Validation(False, ("the answer is empty",), (), (), 0.0)
    try:
        data = json.loads(_strip_fences(text))
    except json.JSONDecodeError as err:
        return Validation(False, (f"the answer is not valid JSON ({err.msg} at position {err.pos})",), (), (), 0.0)
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
        return Validation(False, ('the answer must be a JSON object with an "objects" list',), (), (), 0.0)
    seen: dict[int, int] = {}
    candidates: dict[int, dict[str, Any]] = {}
    for k, item in enumerate(data["objects"]):
        where = f"objects[{k}]"
        if not isinstance(item, dict):
            st.errors.append(f"{where} is not an object")
            continue
        did = _as_int(item.get("id"))
        if did is None:
            st.errors.append(f"{where}: id {item.get('id')!r} is not an integer")
            continue
        if did not in visible:
            st.errors.append(f"{where}: id {did} is not one of the marked ids {sorted(visible)}")
            continue
        seen[did] = seen.get(did, 0) + 1
        if seen[did] > 1:
            st.errors.append(f"id {did} appears more than once")
            candidates.pop(did, None)
            continue
        relation = str(item.get("relation", "")).strip().lower()
        if relation not in RELATION_SYNONYMS:
            st.errors.append(f"id {did}: relation {item.get('relation')!r} is not one of {list(RELATIONS)}")
            continue
        if RELATION_SYNONYMS[relation] != relation:
            st.warnings.append(f"id {did}: relation {relation!r} read as {RELATION_SYNONYMS[relation]!r}")
        relation = RELATION_SYNONYMS[relation]
        raw_parent = item.get("parent")
        parent: int | str
        if isinstance(raw_parent, str) and raw_parent.strip().lower() in ROOTS:
            parent = raw_parent.strip().lower()
        elif isinstance(raw_parent, str) and raw_parent.strip().isdigit():
            parent = int(raw_parent.strip())
        elif (as_int := _as_int(raw_parent)) is not None:
            parent = as_int
        else:
            st.errors.append(f"id {did}: parent {raw_parent!r} is not a marked id, 'floor' or 'wall'")
            continue
        if isinstance(parent, int):
            if parent == did:
                st.errors.append(f"id {did} is its own parent")
                continue
            if parent not in visible:
                st.errors.append(f"id {did}: parent {parent} is not one of the marked ids {sorted(visible)}")
                continue
        category = item.get("category")
        if category != categories[did]:
            st.warnings.append(f"id {did}: category {category!r} replaced by the fixed {categories[did]!r}")
        candidates[did] = {"id": did, "category": categories[did], "relation": relation, "parent": parent}
    for did, count in seen.items():
        if count > 1:
            candidates.pop(did, None)
    graph = nx.DiGraph()
    graph.add_edges_from((d, e["parent"]) for d, e in candidates.items() if isinstance(e["parent"], int))
    in_cycle: set[int] = set()
    for cycle in nx.simple_cycles(graph):
        st.errors.append("the parents form a cycle: " + " -> ".join(str(n) for n in [*cycle, cycle[0]]))
        in_cycle.update(cycle)
    for did in in_cycle:
        candidates.pop(did, None)
    coverage = len(candidates) / len(visible) if visible else 1.0
    missing = sorted(visible - set(seen))
    if missing:
        msg = f"ids {missing} have no entry (every marked id needs one)"
        if coverage < min_coverage:
            st.errors.append(msg)
        else:
            st.warnings.append(msg)
    if coverage < min_coverage and not missing:
        st.errors.append(f"only {coverage:.0%} of the marked ids have a valid entry (need {min_coverage:.0%})")
    entries = tuple(candidates[d] for d in sorted(candidates))
    return Validation(not st.errors, tuple(st.errors), tuple(st.warnings), entries, coverage)
