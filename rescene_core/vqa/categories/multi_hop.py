"""Multi-hop spatial reasoning: shared supports, supports of supports, the neighbour in a view."""

from __future__ import annotations

import numpy as np

from rescene_core.records import Relation, Root
from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import FLOOR_ANSWER, Category, Filter, edge_json
from rescene_core.vqa.scene import edge_parent_id


def generate(ctx: QuestionContext) -> None:
    """Add this category's candidates to ``ctx`` (the templates in the order their random draws happen)."""
    cat = Category.MULTI_HOP
    for cid, e in sorted(ctx.edges.items()):
        pid = edge_parent_id(e)
        if e.relation != Relation.RESTS_ON or pid is None:
            continue
        if cid not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        label = ctx.label(cid)
        siblings = [s for s in ctx.children[pid] if int(s.child) != cid and s.relation == Relation.RESTS_ON]
        if siblings:
            sure = [s for s in siblings if ctx.confident(s)]
            if not ctx.confident(e) or not sure:
                ctx.drop(cat, Filter.LOW_CONFIDENCE)
            else:
                pick = sure[int(ctx.rng.integers(len(sure)))]
                ans = ctx.label(int(pick.child))
                exclude = {ctx.label(int(s.child)) for s in ctx.children[pid]} | {label}
                ctx.add(
                    cat,
                    "same_support",
                    f"Which of these objects rests on the same object as the {ctx.ref(cid)}?",
                    ans,
                    ctx.choices(ans, ctx.labels, exclude),
                    (cid, pid, int(pick.child)),
                    {"edges": [edge_json(e), edge_json(pick)]},
                )
        up = ctx.edges.get(pid)
        if up is not None and up.relation == Relation.RESTS_ON:
            if not (ctx.confident(e) and ctx.confident(up)):
                ctx.drop(cat, Filter.LOW_CONFIDENCE)
            else:
                ans = ctx.parent_label(up)
                gp = edge_parent_id(up)
                ctx.add(
                    cat,
                    "support_of_support",
                    f"What is the object under the {ctx.ref(cid)} resting on?",
                    ans,
                    ctx.choices(ans, [*ctx.labels, FLOOR_ANSWER], {label, ctx.label(pid)}),
                    tuple(i for i in (cid, pid, gp) if i is not None),
                    {"edges": [edge_json(e), edge_json(up)]},
                )
    for a in ctx.scene.ids:
        if a not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        others = sorted(
            (float(np.linalg.norm(ctx.obj[b].center - ctx.obj[a].center)), b) for b in ctx.scene.ids if b != a
        )
        if not others:
            continue
        near = others[0][1]
        kids = [k for k in ctx.children[near] if k.relation == Relation.RESTS_ON and int(k.child) != a]
        if not kids:
            continue
        if len(others) > 1 and not ctx.far_enough(others[0][0], others[1][0]):
            ctx.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
            continue
        exclude = {ctx.label(int(k.child)) for k in ctx.children[near]} | {ctx.label(a)}
        picked = ctx.pick_child(cat, kids, exclude)
        if picked is None:
            continue
        pick, ans, options = picked
        ctx.add(
            cat,
            "rests_on_nearest",
            f"Which of these objects rests on the object nearest to the {ctx.ref(a)}?",
            ans,
            options,
            (a, near, int(pick.child)),
            {
                "edges": [edge_json(pick)],
                "nearest": near,
                "center_distance_m": [round(d, 3) for d, _ in others[:2]],
            },
        )
    view_neighbour(ctx)


def view_neighbour(ctx: QuestionContext) -> None:
    """'In this view, which of these rests on the furniture immediately to the left/right of the B?'
    Furniture = objects resting on the floor with a confident edge."""
    cat = Category.MULTI_HOP
    margin = ctx.config.bearing_margin_deg
    furniture = {c for c, e in ctx.edges.items() if e.parent == Root.FLOOR and ctx.confident(e)}
    for vp in ctx.viewpoints:
        vis = [i for i in sorted(vp.visible) if i in furniture]
        bearings = {i: ctx.bearing(vp, ctx.obj[i].center) for i in vis}
        for b in vis:
            if b not in ctx.unique:
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            for side, sign in (("left", -1.0), ("right", 1.0)):
                offs = sorted((sign * (bearings[i] - bearings[b]), i) for i in vis if i != b)
                offs = [(d, i) for d, i in offs if d > -margin]
                if not offs:
                    continue
                if offs[0][0] < margin or (len(offs) > 1 and offs[1][0] - offs[0][0] < margin):
                    ctx.drop(cat, Filter.NEAR_EQUAL_BEARING)
                    continue
                n = offs[0][1]
                kids = [k for k in ctx.children[n] if k.relation == Relation.RESTS_ON]
                if not kids:
                    continue
                picked = ctx.pick_child(cat, kids, {ctx.label(int(k.child)) for k in kids} | {ctx.label(b)})
                if picked is None:
                    continue
                pick, ans, options = picked
                ctx.add(
                    cat,
                    "rests_on_neighbour_in_view",
                    f"In this view, which of these objects rests on the piece of furniture immediately to "
                    f"the {side} of the {ctx.ref(b)}?",
                    ans,
                    options,
                    (b, n, int(pick.child)),
                    {
                        "view": vp.id,
                        "neighbour": n,
                        "side": side,
                        "edges": [edge_json(pick)],
                        "bearing_deg": {str(i): round(bearings[i], 2) for i in (b, n)},
                    },
                    vp,
                )
