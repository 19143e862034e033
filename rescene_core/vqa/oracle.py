"""Answer a generated question from any scene: the check that answers are right, and the measure of how
faithful a reconstruction is for embodied use.

``answer_on(item, scene)`` recomputes the answer of ``item`` in ``scene`` from the objects the question
refers to (``item.object_ids``, the same instance ids in both scenes), the item's camera and its choices,
with no filter and no reference phrase resolution: it returns the one choice that is true in ``scene``, or
None when the question cannot be answered there (a referred object is missing, no or several choices are
true). View questions use the item's recorded visibility, or a fresh render of ``scene`` from the item's
camera when a renderer of ``scene`` is given.

- questions generated from a ground-truth scene must all be answered with their own answer there
  (``tests/vqa/test_oracle.py``);
- ``agreement(items, gt_scene)``: of the questions generated from a pipeline's scene, the fraction whose
  answer in the ground-truth scene is the same.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from rescene_core.records import Relation, Root
from rescene_core.render import Renderer
from rescene_core.vqa.build import scene_source
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.context import distance_band, relative_yaw, yaw_sector
from rescene_core.vqa.dataset import build_vqa
from rescene_core.vqa.items import COMPASS, FLOOR_ANSWER, VqaItem, wall_direction
from rescene_core.vqa.render import Viewpoint, make_renderer, visible_objects
from rescene_core.vqa.scene import VqaScene, edge_parent_id, read_run

LABEL_ONLY = frozenset({"count", "count_in_view", "label_at_view_centre", "facing_wall"})
"""Templates whose question names no object (a label, the view): answerable whatever objects the scene has."""


class _Scene:
    def __init__(self, scene: VqaScene):
        self.scene = scene
        self.obj = {o.id: o for o in scene.objects}
        self.edges = scene.edges()
        self.walls = {w.id: w for w in scene.shell.walls}
        self.wall_names = {w.id: wall_direction(w) for w in scene.shell.walls}

    def label(self, i: int) -> str:
        return self.obj[i].label

    def parent_label(self, i: int) -> str | None:
        e = self.edges.get(i)
        if e is None:
            return None
        pid = edge_parent_id(e)
        if pid is not None:
            return self.label(pid)
        return FLOOR_ANSWER if e.parent == Root.FLOOR else "wall"

    def children(self, pid: int, relation: Relation) -> list[int]:
        return sorted(c for c, e in self.edges.items() if e.relation == relation and edge_parent_id(e) == pid)

    def wall_of(self, i: int) -> int | None:
        e = self.edges.get(i)
        if e is None or e.relation != Relation.MOUNTS_ON or e.parent != Root.WALL or not self.walls:
            return None
        if e.wall_id is not None and e.wall_id in self.walls:
            return e.wall_id
        c = self.obj[i].center
        return min(self.walls, key=lambda w: abs(float(self.walls[w].plane.signed_distance(c[None])[0])))


def _one(true: Iterable[str], choices: tuple[str, ...]) -> str | None:
    hits = [c for c in choices if c in set(true)]
    return hits[0] if len(hits) == 1 else None


def _viewpoint(vp: Viewpoint | None, template: str) -> Viewpoint:
    """The item's camera: every view template's question is generated with one."""
    if vp is None:
        raise ValueError(f"template {template!r} needs the item's viewpoint and it has none")
    return vp


def answer_on(
    item: VqaItem,
    scene: VqaScene,
    config: VqaConfig | None = None,
    renderer: Renderer | None = None,
    views: dict[str, tuple[dict[int, int], int]] | None = None,
) -> str | None:
    """The choice of ``item`` that is true in ``scene``, or None when the question cannot be answered there.

    views: a cache of the fresh renders (view id -> visible objects, centre id) shared by the questions of
    one scene's views."""
    config = config or VqaConfig()
    s = _Scene(scene)
    ids = [int(i) for i in item.object_ids]
    if item.template not in LABEL_ONLY and any(i not in s.obj for i in ids):
        return None
    names = {int(k): v for k, v in item.provenance.get("names", {}).items()}
    prov: dict[str, Any] = item.provenance
    vp = None if item.viewpoint is None else Viewpoint.from_json(item.viewpoint)
    visible, centre = ({}, 0) if vp is None else (vp.visible, vp.center_id)
    if vp is not None and renderer is not None:
        if views is None or vp.id not in views:
            frame = renderer.render(vp.camera)
            h, w = frame.ids.shape
            seen = (visible_objects(frame.ids, config.min_visible_pixels), max(int(frame.ids[h // 2, w // 2]), 0))
            if views is not None:
                views[vp.id] = seen
        else:
            seen = views[vp.id]
        visible, centre = seen
    t = item.template
    edges = config.distance_band_edges

    def nearer(a: int, b: int, point: np.ndarray) -> str:
        da, db = (float(np.linalg.norm(s.obj[i].center - point)) for i in (a, b))
        return names[a] if da < db else names[b]

    if t == "label_at_position":
        return s.label(ids[0])
    if t == "count":
        return str(sum(o.label == prov["label"] for o in scene.objects))
    if t == "label_at_view_centre":
        return s.label(centre) if centre in s.obj else None
    if t == "count_in_view":
        return str(sum(1 for i in visible if i in s.obj and s.label(i) == prov["label"]))
    if t == "left_right_in_view":
        a, b = ids
        cam = _viewpoint(vp, t).camera.cam_from_world

        def bearing(p: np.ndarray) -> float:
            q = cam[:3, :3] @ p + cam[:3, 3]
            return float(np.arctan2(q[0], q[2]))

        return "left" if bearing(s.obj[a].center) < bearing(s.obj[b].center) else "right"
    if t == "closer_to_camera":
        return nearer(ids[0], ids[1], _viewpoint(vp, t).eye)
    if t == "higher":
        a, b = ids
        return names[a] if s.obj[a].center[2] > s.obj[b].center[2] else names[b]
    if t == "closer_to_object":
        a, b, c = ids
        return nearer(b, c, s.obj[a].center)
    if t == "distance_between":
        return distance_band(float(np.linalg.norm(s.obj[ids[0]].center - s.obj[ids[1]].center)), edges, 0.0)[0]
    if t == "distance_to_camera":
        return distance_band(float(np.linalg.norm(s.obj[ids[0]].center - _viewpoint(vp, t).eye)), edges, 0.0)[0]
    if t == "facing_wall":
        fwd = _viewpoint(vp, t).camera.world_from_cam[:3, 2]
        heading = float(np.degrees(np.arctan2(fwd[1], fwd[0])) % 360.0)
        name = COMPASS[int(((heading + 45.0) % 360.0) // 90.0)]
        return f"{name} wall" if name in s.wall_names.values() else None
    if t == "object_direction":
        return yaw_sector(relative_yaw(_viewpoint(vp, t).camera.world_from_cam, s.obj[ids[0]].center), 0.0)[0]
    if t == "nearest_to_camera":
        eye = _viewpoint(vp, t).eye
        best = min(ids, key=lambda i: float(np.linalg.norm(s.obj[i].center - eye)))
        return names[best]
    if t == "behind_camera":
        wf = _viewpoint(vp, t).camera.world_from_cam
        return _one(
            [names[i] for i in ids if yaw_sector(relative_yaw(wf, s.obj[i].center), 0.0)[0] == "behind"], item.choices
        )
    if t == "rests_on":
        e = s.edges.get(ids[0])
        return s.parent_label(ids[0]) if e is not None and e.relation == Relation.RESTS_ON else None
    if t == "what_rests_on":
        return _one([s.label(c) for c in s.children(ids[0], Relation.RESTS_ON)], item.choices)
    if t == "which_wall":
        wid = s.wall_of(ids[0])
        return None if wid is None else f"{s.wall_names[wid]} wall"
    if t == "mounted_on_object":
        e = s.edges.get(ids[0])
        return s.parent_label(ids[0]) if e is not None and e.relation == Relation.MOUNTS_ON else None
    if t == "mounted_on_a_wall":
        return _one([s.label(i) for i in s.obj if s.wall_of(i) is not None], item.choices)
    if t == "what_on_wall":
        wall_name = s.wall_names.get(int(prov["wall_id"]))
        return _one(
            [s.label(i) for i in s.obj if (w := s.wall_of(i)) is not None and s.wall_names[w] == wall_name],
            item.choices,
        )
    if t == "same_support":
        e = s.edges.get(ids[0])
        pid = None if e is None or e.relation != Relation.RESTS_ON else edge_parent_id(e)
        if pid is None:
            return None
        return _one([s.label(c) for c in s.children(pid, Relation.RESTS_ON) if c != ids[0]], item.choices)
    if t == "support_of_support":
        e = s.edges.get(ids[0])
        pid = None if e is None or e.relation != Relation.RESTS_ON else edge_parent_id(e)
        if pid is None:
            return None
        up = s.edges.get(pid)
        return None if up is None or up.relation != Relation.RESTS_ON else s.parent_label(pid)
    if t == "rests_on_nearest":
        a = ids[0]
        near = min((i for i in s.obj if i != a), key=lambda i: float(np.linalg.norm(s.obj[i].center - s.obj[a].center)))
        return _one([s.label(c) for c in s.children(near, Relation.RESTS_ON) if c != a], item.choices)
    if t == "rests_on_neighbour_in_view":
        b, sign = ids[0], (-1.0 if prov["side"] == "left" else 1.0)
        cam = _viewpoint(vp, t).camera.cam_from_world
        furniture = [i for i in visible if i in s.edges and s.edges[i].parent == Root.FLOOR]

        def bearing_deg(i: int) -> float:
            q = cam[:3, :3] @ s.obj[i].center + cam[:3, 3]
            return float(np.degrees(np.arctan2(q[0], q[2])))

        offs = sorted((sign * (bearing_deg(i) - bearing_deg(b)), i) for i in furniture if i != b)
        offs = [(d, i) for d, i in offs if d > 0]
        if not offs:
            return None
        return _one([s.label(c) for c in s.children(offs[0][1], Relation.RESTS_ON)], item.choices)
    raise ValueError(f"no oracle for template {t!r}")


def agreement(
    items: Iterable[VqaItem], gt_scene: VqaScene, config: VqaConfig | None = None, renderer: Renderer | None = None
) -> dict[str, Any]:
    """How many questions (generated from a pipeline's scene) have the same answer in ``gt_scene``.

    Returns {"questions", "agree", "disagree", "unanswerable" (no single true choice in the ground truth, or
    a referred object is not in it), "agreement" (agree / questions), "per_template" and "per_task":
    {name: {"agree", "disagree", "unanswerable"}}}. View questions re-render each view once."""
    rows: dict[str, dict[str, int]] = {}
    tasks: dict[str, dict[str, int]] = {}
    total = {"agree": 0, "disagree": 0, "unanswerable": 0}
    views: dict[str, tuple[dict[int, int], int]] = {}
    for item in items:
        got = answer_on(item, gt_scene, config, renderer, views)
        key = "unanswerable" if got is None else ("agree" if got == item.answer else "disagree")
        total[key] += 1
        rows.setdefault(item.template, {"agree": 0, "disagree": 0, "unanswerable": 0})[key] += 1
        tasks.setdefault(item.task.value, {"agree": 0, "disagree": 0, "unanswerable": 0})[key] += 1
    n = sum(total.values())
    return {
        "questions": n,
        **total,
        "agreement": total["agree"] / n if n else None,
        "per_template": rows,
        "per_task": tasks,
    }


def run_faithfulness(run_dir, capture, config: VqaConfig | None = None) -> dict[str, Any]:
    """Generate questions from an assembled run and answer them on its capture's ground truth (``agreement``,
    view questions on fresh renders of the ground truth), with the agreement per Table 4 task type.

    Also checks the ground truth against itself: questions generated from it must all agree (``gt_self``)."""

    config = config or VqaConfig(sampling="walk")
    run_scene = read_run(run_dir)
    gt_scene = scene_source(str(capture)).load()
    renderer = make_renderer(gt_scene, config)
    result = agreement(build_vqa(run_scene, config).items, gt_scene, config, renderer)
    own = build_vqa(gt_scene, config).items
    return {
        **result,
        "objects": {"run": len(run_scene.objects), "ground_truth": len(gt_scene.objects)},
        "gt_self": agreement(own, gt_scene, config, renderer)["agreement"],
    }
