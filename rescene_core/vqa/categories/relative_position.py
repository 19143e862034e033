"""Relative position: left/right and nearer in a view, higher, closer to an object."""

from __future__ import annotations

import itertools

import numpy as np

from rescene_core.vqa.context import QuestionContext
from rescene_core.vqa.items import Category, Filter


def generate(ctx: QuestionContext) -> None:
    """Add this category's candidates to ``ctx`` (the templates in the order their random draws happen)."""
    cat = Category.RELATIVE_POSITION
    for vp in ctx.viewpoints:
        vis = sorted(i for i in vp.visible if i in ctx.obj)
        for a, b in itertools.combinations(vis, 2):
            if a not in ctx.unique or b not in ctx.unique:
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            if ctx.rng.random() < 0.5:
                a, b = b, a
            oa, ob = ctx.obj[a], ctx.obj[b]
            ba, bb = ctx.bearing(vp, oa.center), ctx.bearing(vp, ob.center)
            if abs(ba - bb) < ctx.config.bearing_margin_deg:
                ctx.drop(cat, Filter.NEAR_EQUAL_BEARING)
            else:
                ans = "left" if ba < bb else "right"
                ctx.add(
                    cat,
                    "left_right_in_view",
                    f"In this view, is the {ctx.ref(a)} to the left or to the right of the {ctx.ref(b)}?",
                    ans,
                    ctx.shuffle(["left", "right"]),
                    (a, b),
                    {"view": vp.id, "bearing_deg": {str(a): round(ba, 2), str(b): round(bb, 2)}},
                    vp,
                )
            da, db = (float(np.linalg.norm(o.center - vp.eye)) for o in (oa, ob))
            if not ctx.far_enough(da, db):
                ctx.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
            else:
                ans = ctx.ref(a) if da < db else ctx.ref(b)
                ctx.add(
                    cat,
                    "closer_to_camera",
                    f"In this view, which is closer to the camera: the {ctx.ref(a)} or the {ctx.ref(b)}?",
                    ans,
                    ctx.shuffle([ctx.ref(a), ctx.ref(b)]),
                    (a, b),
                    {"view": vp.id, "distance_m": {str(a): round(da, 3), str(b): round(db, 3)}},
                    vp,
                )
    ids = ctx.scene.ids
    for a, b in itertools.combinations(ids, 2):
        if a not in ctx.unique or b not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        if ctx.rng.random() < 0.5:
            a, b = b, a
        oa, ob = ctx.obj[a], ctx.obj[b]
        za, zb = float(oa.center[2]), float(ob.center[2])
        if abs(za - zb) < ctx.config.height_margin:
            ctx.drop(cat, Filter.NEAR_EQUAL_HEIGHT)
            continue
        ans = ctx.ref(a) if za > zb else ctx.ref(b)
        ctx.add(
            cat,
            "higher",
            f"Which is higher up: the {ctx.ref(a)} or the {ctx.ref(b)}?",
            ans,
            ctx.shuffle([ctx.ref(a), ctx.ref(b)]),
            (a, b),
            {"center_z_m": {str(a): round(za, 3), str(b): round(zb, 3)}},
        )
    for a in ids:
        for b, c in itertools.combinations([i for i in ids if i != a], 2):
            if not {a, b, c} <= ctx.unique:
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            if ctx.rng.random() < 0.5:
                b, c = c, b
            oa, ob, oc = ctx.obj[a], ctx.obj[b], ctx.obj[c]
            db, dc = (float(np.linalg.norm(o.center - oa.center)) for o in (ob, oc))
            if not ctx.far_enough(db, dc):
                ctx.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
                continue
            ans = ctx.ref(b) if db < dc else ctx.ref(c)
            ctx.add(
                cat,
                "closer_to_object",
                f"Is the {ctx.ref(a)} closer to the {ctx.ref(b)} or to the {ctx.ref(c)}?",
                ans,
                ctx.shuffle([ctx.ref(b), ctx.ref(c)]),
                (a, b, c),
                {"center_distance_m": {f"{a}-{b}": round(db, 3), f"{a}-{c}": round(dc, 3)}},
            )
    metric_distance(ctx)


def metric_distance(ctx: QuestionContext) -> None:
    """Metric distance judgement with tolerance bands as choices: between two objects' centres, and from
    the camera to a visible object's centre. Distances within ``distance_band_margin`` of a band edge are
    not asked about."""
    cat = Category.RELATIVE_POSITION
    ids = ctx.scene.ids
    for a, b in itertools.combinations(ids, 2):
        if a not in ctx.unique or b not in ctx.unique:
            ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
            continue
        d = float(np.linalg.norm(ctx.obj[a].center - ctx.obj[b].center))
        ans, near = ctx.band(d)
        if near:
            ctx.drop(cat, Filter.NEAR_BAND_EDGE)
            continue
        ctx.add(
            cat,
            "distance_between",
            f"About how far apart are the centres of the {ctx.ref(a)} and the {ctx.ref(b)}?",
            ans,
            ctx.band_choices(ans),
            (a, b),
            {"center_distance_m": round(d, 3)},
        )
    for vp in ctx.viewpoints:
        for a in sorted(i for i in vp.visible if i in ctx.obj):
            if a not in ctx.unique:
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            d = float(np.linalg.norm(ctx.obj[a].center - vp.eye))
            ans, near = ctx.band(d)
            if near:
                ctx.drop(cat, Filter.NEAR_BAND_EDGE)
                continue
            ctx.add(
                cat,
                "distance_to_camera",
                f"In this view, about how far from the camera is the centre of the {ctx.ref(a)}?",
                ans,
                ctx.band_choices(ans),
                (a,),
                {"view": vp.id, "distance_m": round(d, 3)},
                vp,
            )
