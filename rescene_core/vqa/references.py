"""Referring phrases: how a question names an object so that exactly one object fits."""

from __future__ import annotations

from collections import Counter, defaultdict
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rescene_core.vqa.context import QuestionContext


def object_references(ctx: QuestionContext) -> dict[int, str]:
    """A referring phrase (without 'the') for every object that can be named without ambiguity.

    A unique label names its object ('lamp'). A shared label is narrowed by a confident support or
    mount ('table lamp on the desk') when no other object with that label has the same parent label,
    else by the nearest uniquely labelled landmark ('chair nearest to the sofa') when the next object
    with that label is farther from the landmark by ``distance_margin``. Otherwise the object has no
    reference and questions that would name it are dropped (``ambiguous_reference``).
    """
    refs: dict[int, str] = {o.id: o.label for o in ctx.scene.objects if ctx.counts[o.label] == 1}
    landmarks = sorted(refs)
    by_label: dict[str, list[int]] = defaultdict(list)
    for o in ctx.scene.objects:
        by_label[o.label].append(o.id)
    for label, ids in sorted(by_label.items()):
        if len(ids) == 1:
            continue
        support = {}
        for i in ids:
            e = ctx.edges.get(i)
            if e is not None and ctx.confident(e):
                support[i] = ctx.parent_label(e)
        support_counts = Counter(support.get(i) for i in ids)
        for i in sorted(ids):
            parent = support.get(i)
            if parent is not None and parent != "wall" and support_counts[parent] == 1:
                refs[i] = f"{label} on the {parent}"
                continue
            centre = ctx.obj[i].center
            for lm in sorted(landmarks, key=lambda m: (float(np.linalg.norm(ctx.obj[m].center - centre)), m)):
                dist = sorted((float(np.linalg.norm(ctx.obj[j].center - ctx.obj[lm].center)), j) for j in ids)
                if dist[0][1] == i and ctx.far_enough(dist[0][0], dist[1][0]):
                    refs[i] = f"{label} nearest to the {ctx.obj[lm].label}"
                    break
    return refs
