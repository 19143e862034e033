"""Programmatic question-answer generation from the structured scene (paper appendix 'VQA Data Generation').

Five categories: object recognition, relative position, support relation, attachment relation and
multi-hop spatial reasoning. Every answer is computed from the scene (boxes, scene-graph edges, shell,
camera poses). Candidates that would be ambiguous are dropped and counted by reason:

- ``ambiguous_reference``: the question names an object by a label that several objects share;
- ``low_confidence``: a relation the answer depends on has confidence below ``min_confidence``;
- ``near_equal_distance`` / ``near_equal_height`` / ``near_equal_bearing``: the compared quantities
  differ by less than the configured margin;
- ``ambiguous_wall``: two walls get the same compass name;
- ``answer_in_question``: the object's only reference names the support being asked about;
- ``no_distractors``: the scene has no wrong answer that is surely wrong.

The parts: ``items`` (records and vocabulary), ``references`` (how an object is named), ``context`` (the
scene's lookup tables and the shared helpers), ``categories/`` (one module of templates per category),
``selection`` (which candidates are kept). Everything is deterministic given ``VqaConfig.seed``.
"""

from __future__ import annotations

import numpy as np

from rescene_core.records import Relation
from rescene_core.vqa.categories import CATEGORY_GENERATORS
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import (
    COMPASS,
    EXTRA_LABELS,
    FLOOR_ANSWER,
    Category,
    Filter,
    GeneratedQuestions,
    VqaItem,
    plural,
    wall_direction,
)
from rescene_core.vqa.render import Viewpoint
from rescene_core.vqa.scene import VqaScene
from rescene_core.vqa.selection import select


def generate_questions(
    scene: VqaScene, config: VqaConfig | None = None, viewpoints: list[Viewpoint] | tuple[Viewpoint, ...] = ()
) -> GeneratedQuestions:
    """Question-answer items for ``scene`` (and, for view-dependent templates, ``viewpoints``).

    Deterministic given ``config.seed`` and the inputs. Answers come from the boxes, edges and camera poses;
    ambiguous candidates are dropped and counted in ``filtered``.
    """
    config = config or VqaConfig()
    rng = np.random.default_rng(config.seed)
    ctx = QuestionContext(scene, config, list(viewpoints), rng)
    if scene.missing_graph is not None:
        for cat in (Category.SUPPORT_RELATION, Category.ATTACHMENT_RELATION, Category.MULTI_HOP):
            ctx.drop(cat, Filter.MISSING_GRAPH)
    for e in scene.dangling_edges():
        rests = e.relation == Relation.RESTS_ON
        ctx.drop(Category.SUPPORT_RELATION if rests else Category.ATTACHMENT_RELATION, Filter.MISSING_INSTANCE)
    for _category, generate in CATEGORY_GENERATORS:
        generate(ctx)
    items = select(ctx)
    return GeneratedQuestions(
        items=items,
        candidates={c.value: len(ctx.candidates[c]) for c in Category},
        filtered={c.value: dict(sorted(ctx.filtered[c].items())) for c in Category},
    )


__all__ = [
    "COMPASS",
    "EXTRA_LABELS",
    "FLOOR_ANSWER",
    "Category",
    "Filter",
    "GeneratedQuestions",
    "VqaItem",
    "generate_questions",
    "plural",
    "wall_direction",
]
