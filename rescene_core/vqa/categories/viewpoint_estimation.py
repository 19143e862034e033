"""Viewpoint estimation (the paper's Table 4 task; reported under the appendix's relative-position
category): where the camera stands and which way it faces, read from the view.

Templates: ``facing_wall`` (which wall the camera faces), ``object_direction`` (is an object ahead, left,
right or behind), ``nearest_to_camera`` (which object the camera stands nearest to), ``behind_camera``
(which object is behind the camera). Directions are horizontal, relative to the camera's heading.
"""

from __future__ import annotations

import numpy as np

from rescene_core.vqa.context import QuestionContext, yaw_sector
from rescene_core.vqa.items import COMPASS, Category, Filter

SECTORS = ("ahead", "left", "behind", "right")


def generate(ctx: QuestionContext) -> None:
    """Add the viewpoint-estimation candidates of every view to ``ctx``."""
    cat = Category.RELATIVE_POSITION
    margin = ctx.config.sector_margin_deg
    present_walls = sorted(set(ctx.wall_names.values()), key=COMPASS.index)
    for vp in ctx.viewpoints:
        fwd = vp.camera.world_from_cam[:3, 2]
        heading = float(np.degrees(np.arctan2(fwd[1], fwd[0])) % 360.0)
        # the wall the camera faces: compass sector of the heading
        off = (heading + 45.0) % 90.0
        name = COMPASS[int(((heading + 45.0) % 360.0) // 90.0)]
        if min(off, 90.0 - off) < margin:
            ctx.drop(cat, Filter.NEAR_SECTOR_BOUNDARY)
        elif ctx.wall_name_counts.get(name, 0) != 1:
            ctx.drop(cat, Filter.AMBIGUOUS_WALL)
        else:
            ans = f"{name} wall"
            opts = [f"{n} wall" for n in present_walls if n != name]
            ctx.add(
                cat,
                "facing_wall",
                "Which wall is the camera facing in this view?",
                ans,
                ctx.choices(ans, opts) if opts else None,
                (),
                {"view": vp.id, "heading_deg": round(heading, 2)},
                vp,
            )
        rel = {i: ctx.relative_yaw(vp, ctx.obj[i].center) for i in ctx.scene.ids}
        sectors = {i: yaw_sector(a, margin) for i, a in rel.items()}
        for a in ctx.scene.ids:
            if a not in ctx.unique:
                ctx.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            sector, near = sectors[a]
            if near:
                ctx.drop(cat, Filter.NEAR_SECTOR_BOUNDARY)
                continue
            ctx.add(
                cat,
                "object_direction",
                f"Relative to the direction the camera faces, where is the {ctx.ref(a)}: ahead, to the left, "
                f"to the right or behind?",
                sector,
                ctx.shuffle(list(SECTORS)),
                (a,),
                {"view": vp.id, "relative_yaw_deg": round(rel[a], 2)},
                vp,
            )
        dist = sorted((float(np.linalg.norm(ctx.obj[i].center - vp.eye)), i) for i in ctx.scene.ids)
        named = [(d, i) for d, i in dist if i in ctx.unique]
        if len(named) >= 2 and dist[0][1] in ctx.unique:
            if not ctx.far_enough(dist[0][0], dist[1][0]):
                ctx.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
            else:
                near_id = dist[0][1]
                others = [i for d, i in named[1:] if ctx.far_enough(dist[0][0], d)]
                picked = [others[k] for k in ctx.rng.permutation(len(others))[: ctx.config.num_choices - 1]]
                ids = (near_id, *picked)
                ctx.add(
                    cat,
                    "nearest_to_camera",
                    "Which of these objects is the camera standing nearest to?",
                    ctx.ref(near_id),
                    ctx.shuffle([ctx.ref(i) for i in ids]) if picked else None,
                    ids,
                    {"view": vp.id, "distance_m": {str(i): round(d, 3) for d, i in dist if i in ids}},
                    vp,
                )
        behind = [i for i in ctx.scene.ids if sectors[i] == ("behind", False) and i in ctx.unique]
        ahead = [i for i in vp.visible if i in ctx.obj and sectors[i] == ("ahead", False) and i in ctx.unique]
        behind_labels = {ctx.label(i) for i, s in sectors.items() if s[0] == "behind" or s[1]}
        ahead = sorted(i for i in ahead if ctx.label(i) not in behind_labels)
        if behind:
            pick = behind[int(ctx.rng.integers(len(behind)))]
            picked = [ahead[k] for k in ctx.rng.permutation(len(ahead))[: ctx.config.num_choices - 1]]
            ids = (pick, *picked)
            ctx.add(
                cat,
                "behind_camera",
                "Which of these objects is behind the camera?",
                ctx.ref(pick),
                ctx.shuffle([ctx.ref(i) for i in ids]) if picked else None,
                ids,
                {"view": vp.id, "relative_yaw_deg": {str(i): round(rel[i], 2) for i in ids}},
                vp,
            )
