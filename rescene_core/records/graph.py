"""The scene graph: confidence-weighted rests-on / mounts-on edges forming a forest rooted at floor / wall."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rescene_core.records.ids import InstanceId, Parent, Relation, Root, _same_parent, parent_from_json, parent_to_json


@dataclass(frozen=True)
class Edge:
    """Scene-graph edge into ``child``: (c_k, r_k, p_k, omega_k).

    confidence: omega in [0, 1]. scores: fusion terms (V, G, Phi, shell, S). flags: e.g. 'uncertain'.
    wall_id: the concrete wall a 'mounts-on wall' edge was resolved to, when known.
    """

    child: InstanceId
    relation: Relation
    parent: Parent
    confidence: float = 1.0
    scores: dict[str, float] = field(default_factory=dict)
    flags: tuple[str, ...] = ()
    wall_id: int | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "child": int(self.child),
            "relation": self.relation.value,
            "parent": parent_to_json(self.parent),
            "confidence": float(self.confidence),
            "scores": {k: float(v) for k, v in self.scores.items()},
            "flags": list(self.flags),
            "wall_id": self.wall_id,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Edge:
        return cls(
            child=InstanceId(int(d["child"])),
            relation=Relation(d["relation"]),
            parent=parent_from_json(d["parent"]),
            confidence=float(d.get("confidence", 1.0)),
            scores={k: float(v) for k, v in d.get("scores", {}).items()},
            flags=tuple(d.get("flags", ())),
            wall_id=None if d.get("wall_id") is None else int(d["wall_id"]),
        )


@dataclass(frozen=True)
class SceneGraph:
    """A forest over instances rooted at floor/wall: at most one incoming edge per child."""

    edges: tuple[Edge, ...]

    def parent_of(self) -> dict[InstanceId, Edge]:
        return {e.child: e for e in self.edges}

    def children(self, parent: Parent, relation: Relation | None = None) -> list[InstanceId]:
        """The children of ``parent`` (an instance or a root), sorted by id; only those attached by
        ``relation`` when it is given."""
        return sorted(
            e.child
            for e in self.edges
            if (relation is None or e.relation == relation) and _same_parent(e.parent, parent)
        )

    def descendants(self, instance: InstanceId, relation: Relation | None = None) -> list[InstanceId]:
        """Its children, then theirs (breadth first, each once; a cycle back to ``instance`` stops there)."""
        out: list[InstanceId] = []
        todo = self.children(instance, relation)
        while todo:
            c = todo.pop(0)
            if c not in out and c != instance:
                out.append(c)
                todo += self.children(c, relation)
        return out

    def object_parents(self, relation: Relation | None = None) -> dict[InstanceId, InstanceId]:
        """Child -> the object it is attached to (edges to another object, not to the floor or a wall)."""
        return {
            e.child: InstanceId(int(e.parent))
            for e in self.edges
            if (relation is None or e.relation == relation) and not isinstance(e.parent, Root)
        }

    def check(self) -> list[str]:
        """Reasons the graph is not a valid forest (duplicate children, self loops, cycles, dangling parents)."""
        problems: list[str] = []
        by_child: dict[InstanceId, Edge] = {}
        for e in self.edges:
            if e.child in by_child:
                problems.append(f"instance {e.child} has more than one parent")
            by_child[e.child] = e
            if not isinstance(e.parent, Root) and e.parent == e.child:
                problems.append(f"instance {e.child} is its own parent")
        for e in self.edges:
            if not isinstance(e.parent, Root) and e.parent not in by_child:
                problems.append(f"instance {e.child} has parent {e.parent}, which has no edge to a root")
        for start in by_child:
            seen = {start}
            node: Parent = by_child[start].parent
            while not isinstance(node, Root) and node in by_child:
                if node in seen:
                    problems.append(f"cycle through instance {start}")
                    break
                seen.add(node)
                node = by_child[node].parent
        return problems

    def to_json(self) -> dict[str, Any]:
        return {"edges": [e.to_json() for e in self.edges]}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SceneGraph:
        return cls(tuple(Edge.from_json(e) for e in d["edges"]))
