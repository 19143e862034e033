"""Support relation: what an object rests on, which object rests on a given one."""

from __future__ import annotations

from rescene_core.records import Relation
from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import FLOOR_ANSWER, Category, Filter, edge_json
from rescene_core.vqa.scene import edge_parent_id


def generate(ctx: QuestionContext) -> None:
    """Add this category's candidates to ``ctx`` (the templates in the order their random draws happen)."""
    cat = Category.SUPPORT_RELATION
    for cid, e in sorted(ctx.edges.items()):
        if e.relation != Relation.RESTS_ON:
            continue
        if cid not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        if not ctx.confident(e):
            ctx.drop(cat, Filter.LOW_CONFIDENCE)
            continue
        if ctx.by_support(cid):
            ctx.drop(cat, Filter.ANSWER_IN_QUESTION)
            continue
        ans = ctx.parent_label(e)
        pid = edge_parent_id(e)
        ctx.add(
            cat,
            "rests_on",
            f"What is the {ctx.ref(cid)} resting on?",
            ans,
            ctx.choices(ans, [*ctx.labels, FLOOR_ANSWER], {ctx.label(cid)}),
            (cid,) if pid is None else (cid, pid),
            {"edges": [edge_json(e)]},
        )
    for pid in sorted(ctx.children):
        kids = [e for e in ctx.children[pid] if e.relation == Relation.RESTS_ON]
        if not kids:
            continue
        if pid not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        picked = ctx.pick_child(cat, kids, {ctx.label(int(e.child)) for e in kids} | {ctx.label(pid)})
        if picked is None:
            continue
        pick, ans, options = picked
        ctx.add(
            cat,
            "what_rests_on",
            f"Which of these objects rests on the {ctx.ref(pid)}?",
            ans,
            options,
            (pid, int(pick.child)),
            {"edges": [edge_json(pick)], "children": sorted(int(e.child) for e in kids)},
        )
