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

Compass names: world +y is north and +x is east; a wall is named by the direction from the room towards
it (the opposite of its inward normal). Everything is deterministic given ``VqaConfig.seed``.
"""

from __future__ import annotations

import enum
import itertools
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rescene_core.records import Edge, Relation, Root, WallPlane
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.render import Viewpoint
from rescene_core.vqa.scene import VqaScene, edge_parent_id


class Category(enum.StrEnum):
    OBJECT_RECOGNITION = "object_recognition"
    RELATIVE_POSITION = "relative_position"
    SUPPORT_RELATION = "support_relation"
    ATTACHMENT_RELATION = "attachment_relation"
    MULTI_HOP = "multi_hop"


class Filter(enum.StrEnum):
    AMBIGUOUS_REFERENCE = "ambiguous_reference"
    LOW_CONFIDENCE = "low_confidence"
    NEAR_EQUAL_DISTANCE = "near_equal_distance"
    NEAR_EQUAL_HEIGHT = "near_equal_height"
    NEAR_EQUAL_BEARING = "near_equal_bearing"
    AMBIGUOUS_WALL = "ambiguous_wall"
    ANSWER_IN_QUESTION = "answer_in_question"
    NO_DISTRACTORS = "no_distractors"


FLOOR_ANSWER = "floor"

EXTRA_LABELS = (
    "armchair",
    "bookshelf",
    "cabinet",
    "chair",
    "desk",
    "lamp",
    "plant",
    "sofa",
    "table",
    "television",
)
"""Indoor categories used as distractors when the scene itself has too few other labels."""

COMPASS = ("east", "north", "west", "south")


@dataclass(frozen=True)
class VqaItem:
    """One question.

    choices: the multiple-choice options (the answer is one of them). object_ids: every object the
    question or its answer refers to. viewpoint: the camera (Viewpoint.to_json) for view-dependent
    questions, else None. provenance: the edges, boxes and measurements the answer was computed from.
    """

    id: str
    category: Category
    template: str
    question: str
    answer: str
    choices: tuple[str, ...]
    object_ids: tuple[int, ...]
    viewpoint: dict[str, Any] | None = None
    provenance: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "category": self.category.value,
            "template": self.template,
            "question": self.question,
            "answer": self.answer,
            "choices": list(self.choices),
            "object_ids": [int(i) for i in self.object_ids],
            "image": None if self.viewpoint is None else self.viewpoint["image"],
            "viewpoint": self.viewpoint,
            "provenance": self.provenance,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> VqaItem:
        return cls(
            id=str(d["id"]),
            category=Category(d["category"]),
            template=str(d.get("template", "")),
            question=str(d["question"]),
            answer=str(d["answer"]),
            choices=tuple(str(c) for c in d["choices"]),
            object_ids=tuple(int(i) for i in d["object_ids"]),
            viewpoint=d.get("viewpoint"),
            provenance=dict(d.get("provenance", {})),
        )


@dataclass
class GeneratedQuestions:
    """The kept items and the bookkeeping of the filters.

    candidates: per category, unambiguous candidates found. filtered: per category, dropped candidates by
    reason.
    """

    items: list[VqaItem]
    candidates: dict[str, int]
    filtered: dict[str, dict[str, int]]

    def counts(self) -> dict[str, int]:
        out = {c.value: 0 for c in Category}
        for item in self.items:
            out[item.category.value] += 1
        return out


def plural(label: str) -> str:
    """English plural of a label's last word ('book stack' -> 'book stacks', 'shelf' -> 'shelves')."""
    if label.endswith(("s", "x", "ch", "sh")):
        return label + "es"
    if label.endswith("y") and label[-2:-1] not in "aeiou":
        return label[:-1] + "ies"
    if label.endswith("f"):
        return label[:-1] + "ves"
    return label + "s"


def wall_direction(wall: WallPlane) -> str:
    """Compass name of a wall (+y north, +x east): the direction from the room towards the wall."""
    out_x, out_y = -wall.plane.normal[0], -wall.plane.normal[1]
    angle = np.degrees(np.arctan2(out_y, out_x)) % 360.0
    return COMPASS[int(((angle + 45.0) % 360.0) // 90.0)]


def _edge_json(e: Edge) -> dict[str, Any]:
    return {
        "child": int(e.child),
        "relation": e.relation.value,
        "parent": e.to_json()["parent"],
        "confidence": round(float(e.confidence), 4),
        "wall_id": e.wall_id,
    }


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.1f}" for x in v) + ")"


@dataclass
class _Candidate:
    category: Category
    template: str
    question: str
    answer: str
    choices: tuple[str, ...]
    object_ids: tuple[int, ...]
    viewpoint: dict[str, Any] | None
    provenance: dict[str, Any]


class _Generator:
    def __init__(self, scene: VqaScene, config: VqaConfig, viewpoints: list[Viewpoint], rng: np.random.Generator):
        self.scene = scene
        self.config = config
        self.viewpoints = viewpoints
        self.rng = rng
        self.candidates: dict[Category, list[_Candidate]] = {c: [] for c in Category}
        self.filtered: dict[Category, Counter] = {c: Counter() for c in Category}
        self.obj = {o.id: o for o in scene.objects}
        counts = scene.label_counts()
        self.counts = counts
        self.labels = sorted(counts)
        self.edges = scene.edges()
        self.children: dict[int, list[Edge]] = defaultdict(list)
        for e in self.edges.values():
            pid = edge_parent_id(e)
            if pid is not None:
                self.children[pid].append(e)
        self.walls = {w.id: w for w in scene.shell.walls}
        self.wall_names = {w.id: wall_direction(w) for w in scene.shell.walls}
        self.wall_name_counts = Counter(self.wall_names.values())
        self.refs = self._references()
        self.unique = set(self.refs)

    def _references(self) -> dict[int, str]:
        """A referring phrase (without 'the') for every object that can be named without ambiguity.

        A unique label names its object ('lamp'). A shared label is narrowed by a confident support or
        mount ('table lamp on the desk') when no other object with that label has the same parent label,
        else by the nearest uniquely labelled landmark ('chair nearest to the sofa') when the next object
        with that label is farther from the landmark by ``distance_margin``. Otherwise the object has no
        reference and questions that would name it are dropped (``ambiguous_reference``).
        """
        refs: dict[int, str] = {o.id: o.label for o in self.scene.objects if self.counts[o.label] == 1}
        landmarks = sorted(refs)
        by_label: dict[str, list[int]] = defaultdict(list)
        for o in self.scene.objects:
            by_label[o.label].append(o.id)
        for label, ids in sorted(by_label.items()):
            if len(ids) == 1:
                continue
            support = {}
            for i in ids:
                e = self.edges.get(i)
                if e is not None and self.confident(e):
                    support[i] = self.parent_label(e)
            support_counts = Counter(support.get(i) for i in ids)
            for i in sorted(ids):
                parent = support.get(i)
                if parent is not None and parent != "wall" and support_counts[parent] == 1:
                    refs[i] = f"{label} on the {parent}"
                    continue
                centre = self.obj[i].center
                for lm in sorted(landmarks, key=lambda m: (float(np.linalg.norm(self.obj[m].center - centre)), m)):
                    dist = sorted((float(np.linalg.norm(self.obj[j].center - self.obj[lm].center)), j) for j in ids)
                    if dist[0][1] == i and self.far_enough(dist[0][0], dist[1][0]):
                        refs[i] = f"{label} nearest to the {self.obj[lm].label}"
                        break
        return refs

    def by_support(self, oid: int) -> bool:
        """Whether the object's reference names its support ('lamp on the desk')."""
        return self.refs[oid] != self.obj[oid].label and " on the " in self.refs[oid]

    def ref(self, oid: int) -> str:
        """The referring phrase of an object (without 'the')."""
        return self.refs[oid]

    # helpers -----------------------------------------------------------------------------------------
    def label(self, oid: int) -> str:
        return self.obj[oid].label

    def confident(self, e: Edge) -> bool:
        return float(e.confidence) >= self.config.min_confidence

    def pick_confident(self, cat: Category, edges: list[Edge]) -> Edge | None:
        """A random edge of ``edges`` at or above the confidence threshold; None (and a recorded
        low-confidence drop) when there is none."""
        sure = [e for e in edges if self.confident(e)]
        if not sure:
            self.drop(cat, Filter.LOW_CONFIDENCE)
            return None
        return sure[int(self.rng.integers(len(sure)))]

    def pick_child(
        self, cat: Category, edges: list[Edge], exclude: set[str]
    ) -> tuple[Edge, str, tuple[str, ...] | None] | None:
        """For "which of these objects ..." questions: a confident edge of ``edges`` (``pick_confident``),
        its child's label as the answer, and choices from the scene's labels without ``exclude`` (the
        labels that would also be right). None when no edge is confident."""
        pick = self.pick_confident(cat, edges)
        if pick is None:
            return None
        ans = self.label(int(pick.child))
        return pick, ans, self.choices(ans, self.labels, exclude)

    def parent_label(self, e: Edge) -> str:
        pid = edge_parent_id(e)
        return FLOOR_ANSWER if pid is None and e.parent == Root.FLOOR else ("wall" if pid is None else self.label(pid))

    def drop(self, cat: Category, reason: Filter) -> None:
        self.filtered[cat][reason.value] += 1

    def choices(
        self, answer: str, pool: list[str] | set[str], exclude: set[str] = frozenset()
    ) -> tuple[str, ...] | None:
        """The answer plus up to num_choices-1 distractors from ``pool`` (then EXTRA_LABELS), shuffled."""
        bad = set(exclude) | {answer}
        first = sorted({p for p in pool if p not in bad})
        extra = sorted({p for p in EXTRA_LABELS if p not in bad and p not in first and p not in self.labels})
        need = self.config.num_choices - 1
        picked = [first[i] for i in self.rng.permutation(len(first))[:need]]
        if len(picked) < need and extra:
            picked += [extra[i] for i in self.rng.permutation(len(extra))[: need - len(picked)]]
        if not picked:
            return None
        opts = [answer, *picked]
        return tuple(opts[i] for i in self.rng.permutation(len(opts)))

    def shuffle(self, opts: list[str]) -> tuple[str, ...]:
        return tuple(opts[i] for i in self.rng.permutation(len(opts)))

    def add(self, cat, template, question, answer, choices, object_ids, provenance, viewpoint=None) -> None:
        if choices is None:
            self.drop(cat, Filter.NO_DISTRACTORS)
            return
        assert answer in choices
        named = {str(i): self.refs[i] for i in object_ids if self.refs.get(i, self.obj[i].label) != self.obj[i].label}
        if named:
            provenance = {**provenance, "references": named}
        self.candidates[cat].append(
            _Candidate(
                cat,
                template,
                question,
                answer,
                tuple(choices),
                tuple(int(i) for i in object_ids),
                None if viewpoint is None else viewpoint.to_json(),
                provenance,
            )
        )

    def far_enough(self, d1: float, d2: float) -> bool:
        return abs(d1 - d2) >= self.config.distance_margin * max(d1, d2, 1e-9)

    @staticmethod
    def bearing(vp: Viewpoint, point: np.ndarray) -> float:
        """Horizontal angle (degrees) of a world point in the camera frame; positive = right of centre."""
        p = vp.camera.cam_from_world[:3, :3] @ point + vp.camera.cam_from_world[:3, 3]
        return float(np.degrees(np.arctan2(p[0], p[2])))

    def mounted_wall(self, e: Edge) -> int | None:
        """The wall a 'mounts-on wall' edge refers to: its wall_id, else the wall plane nearest the object."""
        if e.wall_id is not None and e.wall_id in self.walls:
            return e.wall_id
        if not self.walls:
            return None
        c = self.obj[int(e.child)].center
        return min(self.walls, key=lambda w: abs(float(self.walls[w].plane.signed_distance(c[None])[0])))

    # templates ---------------------------------------------------------------------------------------
    def object_recognition(self) -> None:
        cat = Category.OBJECT_RECOGNITION
        for o in self.scene.objects:
            self.add(
                cat,
                "label_at_position",
                f"What is the object whose centre is at {_fmt(o.center)} m in room coordinates?",
                o.label,
                self.choices(o.label, self.labels),
                (o.id,),
                {"boxes": {str(o.id): o.to_json()}},
            )
        counts = self.scene.label_counts()
        for label in self.labels:
            n = counts[label]
            ids = [o.id for o in self.scene.objects if o.label == label]
            wrong = [str(k) for k in sorted({max(n + d, 0) for d in (-2, -1, 1, 2, 3)} - {n})]
            opts = [
                str(n),
                *[wrong[i] for i in sorted(self.rng.permutation(len(wrong))[: self.config.num_choices - 1])],
            ]
            self.add(
                cat,
                "count",
                f"How many {plural(label)} are in the room?",
                str(n),
                self.shuffle(opts),
                ids,
                {"objects": ids},
            )
        for vp in self.viewpoints:
            if vp.center_id <= 0 or vp.center_id not in self.obj:
                continue
            lab = self.label(vp.center_id)
            self.add(
                cat,
                "label_at_view_centre",
                "What is the object at the centre of this view?",
                lab,
                self.choices(lab, self.labels),
                (vp.center_id,),
                {"view": vp.id, "center_pixel_id": vp.center_id},
                vp,
            )

    def relative_position(self) -> None:
        cat = Category.RELATIVE_POSITION
        for vp in self.viewpoints:
            vis = sorted(i for i in vp.visible if i in self.obj)
            for a, b in itertools.combinations(vis, 2):
                if a not in self.unique or b not in self.unique:
                    self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                    self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                    continue
                if self.rng.random() < 0.5:
                    a, b = b, a
                oa, ob = self.obj[a], self.obj[b]
                ba, bb = self.bearing(vp, oa.center), self.bearing(vp, ob.center)
                if abs(ba - bb) < self.config.bearing_margin_deg:
                    self.drop(cat, Filter.NEAR_EQUAL_BEARING)
                else:
                    ans = "left" if ba < bb else "right"
                    self.add(
                        cat,
                        "left_right_in_view",
                        f"In this view, is the {self.ref(a)} to the left or to the right of the {self.ref(b)}?",
                        ans,
                        self.shuffle(["left", "right"]),
                        (a, b),
                        {"view": vp.id, "bearing_deg": {str(a): round(ba, 2), str(b): round(bb, 2)}},
                        vp,
                    )
                da, db = (float(np.linalg.norm(o.center - vp.eye)) for o in (oa, ob))
                if not self.far_enough(da, db):
                    self.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
                else:
                    ans = self.ref(a) if da < db else self.ref(b)
                    self.add(
                        cat,
                        "closer_to_camera",
                        f"In this view, which is closer to the camera: the {self.ref(a)} or the {self.ref(b)}?",
                        ans,
                        self.shuffle([self.ref(a), self.ref(b)]),
                        (a, b),
                        {"view": vp.id, "distance_m": {str(a): round(da, 3), str(b): round(db, 3)}},
                        vp,
                    )
        ids = self.scene.ids
        for a, b in itertools.combinations(ids, 2):
            if a not in self.unique or b not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            if self.rng.random() < 0.5:
                a, b = b, a
            oa, ob = self.obj[a], self.obj[b]
            za, zb = float(oa.center[2]), float(ob.center[2])
            if abs(za - zb) < self.config.height_margin:
                self.drop(cat, Filter.NEAR_EQUAL_HEIGHT)
                continue
            ans = self.ref(a) if za > zb else self.ref(b)
            self.add(
                cat,
                "higher",
                f"Which is higher up: the {self.ref(a)} or the {self.ref(b)}?",
                ans,
                self.shuffle([self.ref(a), self.ref(b)]),
                (a, b),
                {"center_z_m": {str(a): round(za, 3), str(b): round(zb, 3)}},
            )
        for a in ids:
            for b, c in itertools.combinations([i for i in ids if i != a], 2):
                if not {a, b, c} <= self.unique:
                    self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                    continue
                if self.rng.random() < 0.5:
                    b, c = c, b
                oa, ob, oc = self.obj[a], self.obj[b], self.obj[c]
                db, dc = (float(np.linalg.norm(o.center - oa.center)) for o in (ob, oc))
                if not self.far_enough(db, dc):
                    self.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
                    continue
                ans = self.ref(b) if db < dc else self.ref(c)
                self.add(
                    cat,
                    "closer_to_object",
                    f"Is the {self.ref(a)} closer to the {self.ref(b)} or to the {self.ref(c)}?",
                    ans,
                    self.shuffle([self.ref(b), self.ref(c)]),
                    (a, b, c),
                    {"center_distance_m": {f"{a}-{b}": round(db, 3), f"{a}-{c}": round(dc, 3)}},
                )

    def support_relation(self) -> None:
        cat = Category.SUPPORT_RELATION
        for cid, e in sorted(self.edges.items()):
            if e.relation != Relation.RESTS_ON:
                continue
            if cid not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            if not self.confident(e):
                self.drop(cat, Filter.LOW_CONFIDENCE)
                continue
            if self.by_support(cid):
                self.drop(cat, Filter.ANSWER_IN_QUESTION)
                continue
            ans = self.parent_label(e)
            pid = edge_parent_id(e)
            self.add(
                cat,
                "rests_on",
                f"What is the {self.ref(cid)} resting on?",
                ans,
                self.choices(ans, [*self.labels, FLOOR_ANSWER], {self.label(cid)}),
                (cid,) if pid is None else (cid, pid),
                {"edges": [_edge_json(e)]},
            )
        for pid in sorted(self.children):
            kids = [e for e in self.children[pid] if e.relation == Relation.RESTS_ON]
            if not kids:
                continue
            if pid not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            picked = self.pick_child(cat, kids, {self.label(int(e.child)) for e in kids} | {self.label(pid)})
            if picked is None:
                continue
            pick, ans, options = picked
            self.add(
                cat,
                "what_rests_on",
                f"Which of these objects rests on the {self.ref(pid)}?",
                ans,
                options,
                (pid, int(pick.child)),
                {"edges": [_edge_json(pick)], "children": sorted(int(e.child) for e in kids)},
            )

    def attachment_relation(self) -> None:
        cat = Category.ATTACHMENT_RELATION
        mounted = {cid: e for cid, e in sorted(self.edges.items()) if e.relation == Relation.MOUNTS_ON}
        present_walls = sorted(set(self.wall_names.values()), key=COMPASS.index)
        on_wall: dict[int, list[Edge]] = defaultdict(list)
        for cid, e in mounted.items():
            wid = self.mounted_wall(e) if e.parent == Root.WALL else None
            if wid is not None:
                on_wall[wid].append(e)
            if cid not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            if not self.confident(e):
                self.drop(cat, Filter.LOW_CONFIDENCE)
                continue
            label = self.label(cid)
            if e.parent == Root.WALL:
                if wid is None:
                    continue
                name = self.wall_names[wid]
                if self.wall_name_counts[name] > 1:
                    self.drop(cat, Filter.AMBIGUOUS_WALL)
                    continue
                ans = f"{name} wall"
                opts = [f"{n} wall" for n in present_walls if n != name]
                self.add(
                    cat,
                    "which_wall",
                    f"On which wall is the {self.ref(cid)} mounted?",
                    ans,
                    self.choices(ans, opts) if opts else None,
                    (cid,),
                    {"edges": [_edge_json(e)], "wall_id": wid, "wall_normal": list(self.walls[wid].plane.normal)},
                )
            elif (pid := edge_parent_id(e)) is not None:
                if self.by_support(cid):
                    self.drop(cat, Filter.ANSWER_IN_QUESTION)
                    continue
                ans = self.label(pid)
                self.add(
                    cat,
                    "mounted_on_object",
                    f"What is the {self.ref(cid)} mounted on?",
                    ans,
                    self.choices(ans, [*self.labels, "wall"], {label}),
                    (cid, pid),
                    {"edges": [_edge_json(e)]},
                )
        mounted_labels = {self.label(c) for c in mounted}
        for cid, e in mounted.items():
            if e.parent != Root.WALL:
                continue
            if not self.confident(e):
                self.drop(cat, Filter.LOW_CONFIDENCE)
                continue
            ans = self.label(cid)
            self.add(
                cat,
                "mounted_on_a_wall",
                "Which of these objects is mounted on a wall?",
                ans,
                self.choices(ans, self.labels, mounted_labels) if len(set(self.labels) - mounted_labels) else None,
                (cid,),
                {"edges": [_edge_json(e)]},
            )
        for wid, es in sorted(on_wall.items()):
            name = self.wall_names[wid]
            if self.wall_name_counts[name] > 1:
                self.drop(cat, Filter.AMBIGUOUS_WALL)
                continue
            picked = self.pick_child(cat, es, {self.label(int(e.child)) for e in es})
            if picked is None:
                continue
            pick, ans, options = picked
            self.add(
                cat,
                "what_on_wall",
                f"Which of these objects is mounted on the {name} wall?",
                ans,
                options,
                (int(pick.child),),
                {"edges": [_edge_json(pick)], "wall_id": wid},
            )

    def multi_hop(self) -> None:
        cat = Category.MULTI_HOP
        for cid, e in sorted(self.edges.items()):
            pid = edge_parent_id(e)
            if e.relation != Relation.RESTS_ON or pid is None:
                continue
            if cid not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            label = self.label(cid)
            siblings = [s for s in self.children[pid] if int(s.child) != cid and s.relation == Relation.RESTS_ON]
            if siblings:
                sure = [s for s in siblings if self.confident(s)]
                if not self.confident(e) or not sure:
                    self.drop(cat, Filter.LOW_CONFIDENCE)
                else:
                    pick = sure[int(self.rng.integers(len(sure)))]
                    ans = self.label(int(pick.child))
                    exclude = {self.label(int(s.child)) for s in self.children[pid]} | {label}
                    self.add(
                        cat,
                        "same_support",
                        f"Which of these objects rests on the same object as the {self.ref(cid)}?",
                        ans,
                        self.choices(ans, self.labels, exclude),
                        (cid, pid, int(pick.child)),
                        {"edges": [_edge_json(e), _edge_json(pick)]},
                    )
            up = self.edges.get(pid)
            if up is not None and up.relation == Relation.RESTS_ON:
                if not (self.confident(e) and self.confident(up)):
                    self.drop(cat, Filter.LOW_CONFIDENCE)
                else:
                    ans = self.parent_label(up)
                    gp = edge_parent_id(up)
                    self.add(
                        cat,
                        "support_of_support",
                        f"What is the object under the {self.ref(cid)} resting on?",
                        ans,
                        self.choices(ans, [*self.labels, FLOOR_ANSWER], {label, self.label(pid)}),
                        tuple(i for i in (cid, pid, gp) if i is not None),
                        {"edges": [_edge_json(e), _edge_json(up)]},
                    )
        for a in self.scene.ids:
            if a not in self.unique:
                self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                continue
            others = sorted(
                (float(np.linalg.norm(self.obj[b].center - self.obj[a].center)), b) for b in self.scene.ids if b != a
            )
            if not others:
                continue
            near = others[0][1]
            kids = [k for k in self.children[near] if k.relation == Relation.RESTS_ON and int(k.child) != a]
            if not kids:
                continue
            if len(others) > 1 and not self.far_enough(others[0][0], others[1][0]):
                self.drop(cat, Filter.NEAR_EQUAL_DISTANCE)
                continue
            exclude = {self.label(int(k.child)) for k in self.children[near]} | {self.label(a)}
            picked = self.pick_child(cat, kids, exclude)
            if picked is None:
                continue
            pick, ans, options = picked
            self.add(
                cat,
                "rests_on_nearest",
                f"Which of these objects rests on the object nearest to the {self.ref(a)}?",
                ans,
                options,
                (a, near, int(pick.child)),
                {
                    "edges": [_edge_json(pick)],
                    "nearest": near,
                    "center_distance_m": [round(d, 3) for d, _ in others[:2]],
                },
            )
        self._view_neighbour()

    def _view_neighbour(self) -> None:
        """'In this view, which of these rests on the furniture immediately to the left/right of the B?'
        Furniture = objects resting on the floor with a confident edge."""
        cat = Category.MULTI_HOP
        margin = self.config.bearing_margin_deg
        furniture = {c for c, e in self.edges.items() if e.parent == Root.FLOOR and self.confident(e)}
        for vp in self.viewpoints:
            vis = [i for i in sorted(vp.visible) if i in furniture]
            bearings = {i: self.bearing(vp, self.obj[i].center) for i in vis}
            for b in vis:
                if b not in self.unique:
                    self.drop(cat, Filter.AMBIGUOUS_REFERENCE)
                    continue
                for side, sign in (("left", -1.0), ("right", 1.0)):
                    offs = sorted((sign * (bearings[i] - bearings[b]), i) for i in vis if i != b)
                    offs = [(d, i) for d, i in offs if d > -margin]
                    if not offs:
                        continue
                    if offs[0][0] < margin or (len(offs) > 1 and offs[1][0] - offs[0][0] < margin):
                        self.drop(cat, Filter.NEAR_EQUAL_BEARING)
                        continue
                    n = offs[0][1]
                    kids = [k for k in self.children[n] if k.relation == Relation.RESTS_ON]
                    if not kids:
                        continue
                    picked = self.pick_child(cat, kids, {self.label(int(k.child)) for k in kids} | {self.label(b)})
                    if picked is None:
                        continue
                    pick, ans, options = picked
                    self.add(
                        cat,
                        "rests_on_neighbour_in_view",
                        f"In this view, which of these objects rests on the piece of furniture immediately to "
                        f"the {side} of the {self.ref(b)}?",
                        ans,
                        options,
                        (b, n, int(pick.child)),
                        {
                            "view": vp.id,
                            "neighbour": n,
                            "edges": [_edge_json(pick)],
                            "bearing_deg": {str(i): round(bearings[i], 2) for i in (b, n)},
                        },
                        vp,
                    )

    def select(self) -> list[VqaItem]:
        """Up to ``per_category`` items per category, round-robin over templates in a seeded order."""
        items: list[VqaItem] = []
        for cat in Category:
            by_template: dict[str, list[_Candidate]] = defaultdict(list)
            for cand in self.candidates[cat]:
                by_template[cand.template].append(cand)
            queues = []
            for name in sorted(by_template):
                group = by_template[name]
                queues.append([group[i] for i in self.rng.permutation(len(group))])
            chosen: list[_Candidate] = []
            while len(chosen) < self.config.per_category and any(queues):
                for q in queues:
                    if q and len(chosen) < self.config.per_category:
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


def generate_questions(
    scene: VqaScene, config: VqaConfig | None = None, viewpoints: list[Viewpoint] | tuple[Viewpoint, ...] = ()
) -> GeneratedQuestions:
    """Question-answer items for ``scene`` (and, for view-dependent templates, ``viewpoints``).

    Deterministic given ``config.seed`` and the inputs. Answers come from the boxes, edges and camera poses;
    ambiguous candidates are dropped and counted in ``filtered``.
    """
    config = config or VqaConfig()
    rng = np.random.default_rng(config.seed)
    gen = _Generator(scene, config, list(viewpoints), rng)
    gen.object_recognition()
    gen.relative_position()
    gen.support_relation()
    gen.attachment_relation()
    gen.multi_hop()
    items = gen.select()
    return GeneratedQuestions(
        items=items,
        candidates={c.value: len(gen.candidates[c]) for c in Category},
        filtered={c.value: dict(sorted(gen.filtered[c].items())) for c in Category},
    )
