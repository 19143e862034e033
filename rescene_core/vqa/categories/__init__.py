"""The question templates, one module per category of the paper's appendix ('VQA Data Generation').

Each module has ``generate(ctx)``, which adds the category's candidates and filter counts to a
``QuestionContext``. ``CATEGORY_GENERATORS`` lists them in the order they run (the order of the random
draws, so it is part of the output).
"""

from __future__ import annotations

from collections.abc import Callable

from rescene_core.vqa.categories import (
    attachment_relation,
    multi_hop,
    object_recognition,
    relative_position,
    support_relation,
    viewpoint_estimation,
)
from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import Category

CATEGORY_GENERATORS: tuple[tuple[Category, Callable[[QuestionContext], None]], ...] = (
    (Category.OBJECT_RECOGNITION, object_recognition.generate),
    (Category.RELATIVE_POSITION, relative_position.generate),
    (Category.SUPPORT_RELATION, support_relation.generate),
    (Category.ATTACHMENT_RELATION, attachment_relation.generate),
    (Category.MULTI_HOP, multi_hop.generate),
    (Category.RELATIVE_POSITION, viewpoint_estimation.generate),
)

__all__ = ["CATEGORY_GENERATORS"]
