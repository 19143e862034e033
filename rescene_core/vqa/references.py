"""Referring phrases: how a question names an object so that exactly one object fits, and the edge and
distance tests they share with the question templates."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Mapping

import numpy as np

from rescene_core.records import Edge, Root
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.items import FLOOR_ANSWER
from rescene_core.vqa.scene import VqaObject, VqaScene, edge_parent_id


def is_confident(edge: Edge, min_confidence: float) -> bool:
    """Whether an edge's confidence is at or above ``min_confidence``."""
    return float(edge.confidence) >= min_confidence


def parent_label(edge: Edge, objects: Mapping[int, VqaObject]) -> str:
    """The label of an edge's parent: its object's label, the floor answer, or 'wall'."""
    pid = edge_parent_id(edge)
    if pid is None:
        return FLOOR_ANSWER if edge.parent == Root.FLOOR else "wall"
    return objects[pid].label


def far_enough(d1: float, d2: float, margin: float) -> bool:
    """Whether two distances (m) differ by at least ``margin`` of the larger one."""
    return abs(d1 - d2) >= margin * max(d1, d2, 1e-9)


def object_references(scene: VqaScene, edges: Mapping[int, Edge], config: VqaConfig) -> dict[int, str]:
    """A referring phrase (without 'the') for every object that can be named without ambiguity.

    A unique label names its object ('lamp'). A shared label is narrowed by a confident support or
    mount ('table lamp on the desk') when no other object with that label has the same parent label,
    else by the nearest uniquely labelled landmark ('chair nearest to the sofa') when the next object
    with that label is farther from the landmark by ``distance_margin``. Otherwise the object has no
    reference and questions that would name it are dropped (``ambiguous_reference``). ``edges`` are
    the scene's edges by child id.
    """
    obj = {o.id: o for o in scene.objects}
    counts = scene.label_counts()
    refs: dict[int, str] = {o.id: o.label for o in scene.objects if counts[o.label] == 1}
    landmarks = sorted(refs)
    by_label: dict[str, list[int]] = defaultdict(list)
    for o in scene.objects:
        by_label[o.label].append(o.id)
    for label, ids in sorted(by_label.items()):
        if len(ids) == 1:
            continue
        support = {}
        for i in ids:
            e = edges.get(i)
            if e is not None and is_confident(e, config.min_confidence):
                support[i] = parent_label(e, obj)
        support_counts = Counter(support.get(i) for i in ids)
        for i in sorted(ids):
            parent = support.get(i)
            if parent is not None and parent != "wall" and support_counts[parent] == 1:
                refs[i] = f"{label} on the {parent}"
                continue
            centre = obj[i].center
            for lm in sorted(landmarks, key=lambda m: (float(np.linalg.norm(obj[m].center - centre)), m)):
                dist = sorted((float(np.linalg.norm(obj[j].center - obj[lm].center)), j) for j in ids)
                if dist[0][1] == i and far_enough(dist[0][0], dist[1][0], config.distance_margin):
                    refs[i] = f"{label} nearest to the {obj[lm].label}"
                    break
    return refs
