"""Traversal of a scene graph (rescene_core/records/graph.py SceneGraph): children, descendants, object parents."""

from __future__ import annotations

from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

I = InstanceId  # noqa: E741 - short in the tables below

GRAPH = SceneGraph(
    (
        Edge(I(2), Relation.RESTS_ON, Root.FLOOR, 0.9),  # a table
        Edge(I(5), Relation.RESTS_ON, I(2), 0.8),  # a tray on it
        Edge(I(3), Relation.RESTS_ON, I(2), 0.8),  # a lamp on it
        Edge(I(7), Relation.RESTS_ON, I(5), 0.7),  # a cup on the tray
        Edge(I(9), Relation.MOUNTS_ON, I(2), 0.6),  # a hook on the table's side
        Edge(I(4), Relation.MOUNTS_ON, Root.WALL, 0.9),
    )
)


def test_children_are_sorted_and_filtered_by_relation():
    assert GRAPH.children(I(2)) == [3, 5, 9]
    assert GRAPH.children(I(2), Relation.RESTS_ON) == [3, 5]
    assert GRAPH.children(Root.FLOOR) == [2] and GRAPH.children(Root.WALL) == [4]
    assert GRAPH.children(I(7)) == []


def test_descendants_breadth_first_and_cycle_safe():
    assert GRAPH.descendants(I(2), Relation.RESTS_ON) == [3, 5, 7]
    assert GRAPH.descendants(I(2)) == [3, 5, 9, 7]
    loop = SceneGraph((Edge(I(1), Relation.RESTS_ON, I(2), 0.5), Edge(I(2), Relation.RESTS_ON, I(1), 0.5)))
    assert loop.descendants(I(1)) == [2]


def test_object_parents_leave_out_the_roots():
    assert GRAPH.object_parents(Relation.RESTS_ON) == {5: 2, 3: 2, 7: 5}
    assert GRAPH.object_parents() == {5: 2, 3: 2, 7: 5, 9: 2}
