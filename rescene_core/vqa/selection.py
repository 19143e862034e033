"""Selection: which of the candidates become the data set's items."""

from __future__ import annotations

from collections import defaultdict

from rescene_core.vqa.context import Candidate, QuestionContext
from rescene_core.vqa.items import Category, VqaItem


def select(ctx: QuestionContext) -> list[VqaItem]:
    """Up to ``per_category`` items per category, round-robin over templates in a seeded order."""
    items: list[VqaItem] = []
    for cat in Category:
        by_template: dict[str, list[Candidate]] = defaultdict(list)
        for cand in ctx.candidates[cat]:
            by_template[cand.template].append(cand)
        queues = []
        for name in sorted(by_template):
            group = by_template[name]
            queues.append([group[i] for i in ctx.rng.permutation(len(group))])
        chosen: list[Candidate] = []
        while len(chosen) < ctx.config.per_category and any(queues):
            for q in queues:
                if q and len(chosen) < ctx.config.per_category:
                    chosen.append(q.pop(0))
        for cand in chosen:
            items.append(
                VqaItem(
                    f"q{len(items):05d}",
                    cat,
                    cand.template,
                    cand.question,
                    cand.answer,
                    cand.choices,
                    cand.object_ids,
                    cand.viewpoint,
                    cand.provenance,
                )
            )
    return items
