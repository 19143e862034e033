"""Object recognition: counts, the label at a position, the object at a view's centre."""

from __future__ import annotations

from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import Category, Filter, fmt_point, plural


def generate(ctx: QuestionContext) -> None:
    """Add this category's candidates to ``ctx`` (the templates in the order their random draws happen)."""
    cat = Category.OBJECT_RECOGNITION
    for o in ctx.scene.objects:
        ctx.add(
            cat,
            "label_at_position",
            f"What is the object whose centre is at {fmt_point(o.center)} m in room coordinates?",
            o.label,
            ctx.choices(o.label, ctx.labels),
            (o.id,),
            {"boxes": {str(o.id): o.to_json()}},
        )
    counts = ctx.scene.label_counts()
    for label in ctx.labels:
        n = counts[label]
        ids = [o.id for o in ctx.scene.objects if o.label == label]
        wrong = [str(k) for k in sorted({max(n + d, 0) for d in (-2, -1, 1, 2, 3)} - {n})]
        opts = [
            str(n),
            *[wrong[i] for i in sorted(ctx.rng.permutation(len(wrong))[: ctx.config.num_choices - 1])],
        ]
        ctx.add(
            cat,
            "count",
            f"How many {plural(label)} are in the room?",
            str(n),
            ctx.shuffle(opts),
            ids,
            {"objects": ids, "label": label},
        )
    for vp in ctx.viewpoints:
        if vp.center_id <= 0 or vp.center_id not in ctx.obj:
            continue
        lab = ctx.label(vp.center_id)
        ctx.add(
            cat,
            "label_at_view_centre",
            "What is the object at the centre of this view?",
            lab,
            ctx.choices(lab, ctx.labels),
            (vp.center_id,),
            {"view": vp.id, "center_pixel_id": vp.center_id},
            vp,
        )
    count_in_view(ctx)


def count_in_view(ctx: QuestionContext) -> None:
    """'How many <label>s can you see in this view?' over the labels seen in each view. A label is not asked
    about when one of its objects covers a pixel count near ``min_visible_pixels`` (within the factor
    ``visibility_margin``): whether it counts as seen would be a coin toss."""
    cat = Category.OBJECT_RECOGNITION
    lo = ctx.config.min_visible_pixels / ctx.config.visibility_margin
    hi = ctx.config.min_visible_pixels * ctx.config.visibility_margin
    for vp in ctx.viewpoints:
        pixels = {**vp.faint, **vp.visible}
        seen = sorted({ctx.label(i) for i in vp.visible if i in ctx.obj})
        for label in seen:
            of_label = [i for i in pixels if i in ctx.obj and ctx.label(i) == label]
            if any(lo <= pixels[i] < hi for i in of_label):
                ctx.drop(cat, Filter.NEAR_VISIBILITY_THRESHOLD)
                continue
            ids = sorted(i for i in of_label if i in vp.visible)
            n = len(ids)
            wrong = [str(k) for k in sorted({max(n + d, 0) for d in (-2, -1, 1, 2, 3)} - {n})]
            opts = [str(n), *[wrong[i] for i in sorted(ctx.rng.permutation(len(wrong))[: ctx.config.num_choices - 1])]]
            ctx.add(
                cat,
                "count_in_view",
                f"How many {plural(label)} can you see in this view?",
                str(n),
                ctx.shuffle(opts),
                ids,
                {"view": vp.id, "label": label, "pixels": {str(i): pixels[i] for i in sorted(of_label)}},
                vp,
            )
