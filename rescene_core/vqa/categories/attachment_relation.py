"""Attachment relation: which wall, mounted on what, what is on a wall."""

from __future__ import annotations

from collections import defaultdict

from rescene_core.records import Edge, Relation, Root
from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import COMPASS, Category, Filter, edge_json
from rescene_core.vqa.scene import edge_parent_id


def generate(ctx: QuestionContext) -> None:
    """Add this category's candidates to ``ctx`` (the templates in the order their random draws happen)."""
    cat = Category.ATTACHMENT_RELATION
    mounted = {cid: e for cid, e in sorted(ctx.edges.items()) if e.relation == Relation.MOUNTS_ON}
    present_walls = sorted(set(ctx.wall_names.values()), key=COMPASS.index)
    on_wall: dict[int, list[Edge]] = defaultdict(list)
    for cid, e in mounted.items():
        wid = ctx.mounted_wall(e) if e.parent == Root.WALL else None
        if wid is not None:
            on_wall[wid].append(e)
        if cid not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        if not ctx.confident(e):
            ctx.drop(cat, Filter.LOW_CONFIDENCE)
            continue
        label = ctx.label(cid)
        if e.parent == Root.WALL:
            if wid is None:
                continue
            name = ctx.wall_names[wid]
            if ctx.wall_name_counts[name] > 1:
                ctx.drop(cat, Filter.AMBIGUOUS_WALL)
                continue
            ans = f"{name} wall"
            opts = [f"{n} wall" for n in present_walls if n != name]
            ctx.add(
                cat,
                "which_wall",
                f"On which wall is the {ctx.ref(cid)} mounted?",
                ans,
                ctx.choices(ans, opts) if opts else None,
                (cid,),
                {"edges": [edge_json(e)], "wall_id": wid, "wall_normal": list(ctx.walls[wid].plane.normal)},
            )
        elif (pid := edge_parent_id(e)) is not None:
            if ctx.by_support(cid):
                ctx.drop(cat, Filter.ANSWER_IN_QUESTION)
                continue
            ans = ctx.label(pid)
            ctx.add(
                cat,
                "mounted_on_object",
                f"What is the {ctx.ref(cid)} mounted on?",
                ans,
                ctx.choices(ans, [*ctx.labels, "wall"], {label}),
                (cid, pid),
                {"edges": [edge_json(e)]},
            )
    mounted_labels = {ctx.label(c) for c in mounted}
    for cid, e in mounted.items():
        if e.parent != Root.WALL:
            continue
        if not ctx.confident(e):
            ctx.drop(cat, Filter.LOW_CONFIDENCE)
            continue
        ans = ctx.label(cid)
        ctx.add(
            cat,
            "mounted_on_a_wall",
            "Which of these objects is mounted on a wall?",
            ans,
            ctx.choices(ans, ctx.labels, mounted_labels) if len(set(ctx.labels) - mounted_labels) else None,
            (cid,),
            {"edges": [edge_json(e)]},
        )
    for wid, es in sorted(on_wall.items()):
        name = ctx.wall_names[wid]
        if ctx.wall_name_counts[name] > 1:
            ctx.drop(cat, Filter.AMBIGUOUS_WALL)
            continue
        picked = ctx.pick_child(cat, es, {ctx.label(int(e.child)) for e in es})
        if picked is None:
            continue
        pick, ans, options = picked
        ctx.add(
            cat,
            "what_on_wall",
            f"Which of these objects is mounted on the {name} wall?",
            ans,
            options,
            (int(pick.child),),
            {"edges": [edge_json(pick)], "wall_id": wid},
        )
