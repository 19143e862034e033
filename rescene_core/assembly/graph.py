"""Turn a SceneGraph into the forest the solver propagates along, recording every edge it must skip.

Edges are kept when their child is an object to place and their parent is a structural root or another
placed object; edges on a cycle, into unknown children, from unknown parents and duplicate edges into a
child are skipped with a reason (their child then keeps its registered pose for the relational layer).
"""

from __future__ import annotations

from dataclasses import dataclass

import networkx as nx

from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph


@dataclass(frozen=True)
class Forest:
    """The usable part of a scene graph.

    edges: child id -> its edge, in topological order (parents before children).
    skipped: (edge, reason) for each edge that was not used.
    """

    edges: dict[InstanceId, Edge]
    skipped: tuple[tuple[Edge, str], ...]
    digraph: nx.DiGraph

    def children(self, node: InstanceId | Root) -> list[InstanceId]:
        return list(self.digraph.successors(node)) if node in self.digraph else []

    def subtree(self, node: InstanceId) -> list[InstanceId]:
        """``node`` and all its descendants."""
        return [node, *nx.descendants(self.digraph, node)] if node in self.digraph else [node]

    def support_of(self, node: InstanceId) -> InstanceId | None:
        """The object ``node`` rests on (its ``rests-on`` edge to an object); None on the floor, mounted on a
        wall, or without an edge."""
        edge = self.edges.get(node)
        if edge is None or edge.relation is not Relation.RESTS_ON or isinstance(edge.parent, Root):
            return None
        return InstanceId(int(edge.parent))

    def root_of(self, node: InstanceId) -> InstanceId:
        """The topmost object ancestor of ``node`` (itself when its parent is a structural root)."""
        while node in self.edges and not isinstance(self.edges[node].parent, Root):
            node = InstanceId(int(self.edges[node].parent))
        return node

    def related(self, a: InstanceId, b: InstanceId) -> bool:
        """Whether one of the two objects is an ancestor of the other (such pairs may touch)."""
        if a not in self.digraph or b not in self.digraph:
            return False
        return nx.has_path(self.digraph, a, b) or nx.has_path(self.digraph, b, a)


def build_forest(graph: SceneGraph, object_ids: set[InstanceId]) -> Forest:
    """Keep the edges of ``graph`` that form a forest over ``object_ids`` rooted at floor/wall."""
    skipped: list[tuple[Edge, str]] = []
    by_child: dict[InstanceId, Edge] = {}
    for e in graph.edges:
        if not 0.0 <= float(e.confidence) <= 1.0:
            skipped.append((e, f"confidence {e.confidence} outside [0, 1]"))
        elif e.child not in object_ids:
            skipped.append((e, f"child {e.child} is not an object to place (missing or unknown)"))
        elif e.child in by_child:
            skipped.append((e, f"child {e.child} already has a parent edge; only the first is used"))
        elif not isinstance(e.parent, Root) and e.parent == e.child:
            skipped.append((e, f"instance {e.child} is its own parent"))
        else:
            by_child[e.child] = e
    digraph = nx.DiGraph()
    digraph.add_nodes_from(object_ids)
    digraph.add_nodes_from([Root.FLOOR, Root.WALL])
    for child, e in by_child.items():
        digraph.add_edge(e.parent, child)
    # cycles: every edge inside a strongly connected component of size > 1 is dropped
    for comp in nx.strongly_connected_components(digraph):
        if len(comp) > 1:
            for child in sorted(c for c in comp if not isinstance(c, Root)):
                e = by_child.pop(child)
                digraph.remove_edge(e.parent, child)
                skipped.append((e, f"edge is on a cycle through instances {sorted(int(c) for c in comp)}"))
    # dangling: a parent that is not an object to place. A parent object without an edge of its own is
    # fine: it keeps its registered pose and its children are still placed on it.
    for child, e in list(by_child.items()):
        if not isinstance(e.parent, Root) and e.parent not in object_ids:
            by_child.pop(child)
            digraph.remove_edge(e.parent, child)
            skipped.append((e, f"parent {e.parent} is not an object to place (dangling parent)"))
    order = [n for n in nx.topological_sort(digraph) if n in by_child]
    return Forest({n: by_child[n] for n in order}, tuple(skipped), digraph)
