"""The shared state of question generation: the scene's lookup tables, the seeded random stream, the
candidates found so far and the filter counts, with the helpers every category's templates use
(confidence checks, choices with distractors, recording drops).

The order of random draws is part of the output: templates draw from one stream in a fixed order, so a
seed gives the same questions.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

import numpy as np

from rescene_core.records import Edge
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.items import EXTRA_LABELS, Category, Filter, wall_direction
from rescene_core.vqa.references import far_enough, is_confident, object_references, parent_label
from rescene_core.vqa.render import Viewpoint
from rescene_core.vqa.scene import VqaScene, edge_parent_id


@dataclass
class Candidate:
    """A question found by a template, before selection (the fields of ``VqaItem`` without the id)."""

    category: Category
    template: str
    question: str
    answer: str
    choices: tuple[str, ...]
    object_ids: tuple[int, ...]
    viewpoint: dict[str, Any] | None
    provenance: dict[str, Any]


class QuestionContext:
    """Lookup tables of one scene (objects by id, labels, edges by child, children by parent, walls and
    their compass names, object references) and the state of one generation run."""

    def __init__(self, scene: VqaScene, config: VqaConfig, viewpoints: list[Viewpoint], rng: np.random.Generator):
        self.scene = scene
        self.config = config
        self.viewpoints = viewpoints
        self.rng = rng
        self.candidates: dict[Category, list[Candidate]] = {c: [] for c in Category}
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
        self.refs = object_references(scene, self.edges, config)
        self.unique = set(self.refs)

    def by_support(self, oid: int) -> bool:
        """Whether the object's reference names its support ('lamp on the desk')."""
        return self.refs[oid] != self.obj[oid].label and " on the " in self.refs[oid]

    def ref(self, oid: int) -> str:
        """The referring phrase of an object (without 'the')."""
        return self.refs[oid]

    def label(self, oid: int) -> str:
        return self.obj[oid].label

    def confident(self, e: Edge) -> bool:
        return is_confident(e, self.config.min_confidence)

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
        return parent_label(e, self.obj)

    def drop(self, cat: Category, reason: Filter) -> None:
        self.filtered[cat][reason.value] += 1

    def choices(
        self, answer: str, pool: list[str] | set[str], exclude: Collection[str] = frozenset()
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
        if answer not in choices:
            raise ValueError(f"template {template!r}: the answer {answer!r} is not among its choices {choices}")
        named = {str(i): self.refs[i] for i in object_ids if self.refs.get(i, self.obj[i].label) != self.obj[i].label}
        if named:
            provenance = {**provenance, "references": named}
        provenance = {**provenance, "names": {str(i): self.refs.get(i, self.obj[i].label) for i in object_ids}}
        self.candidates[cat].append(
            Candidate(
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

    def relative_yaw(self, vp: Viewpoint, point: np.ndarray) -> float:
        """Horizontal angle (degrees, -180..180) of a world point from the camera's heading; positive = left."""
        return relative_yaw(vp.camera.world_from_cam, point)

    def band(self, d: float) -> tuple[str, bool]:
        """The distance band label of ``d`` (m) and whether ``d`` is within ``distance_band_margin`` of an edge."""
        return distance_band(d, self.config.distance_band_edges, self.config.distance_band_margin)

    def band_choices(self, answer: str) -> tuple[str, ...]:
        """The answer band and its nearest neighbouring bands (``num_choices`` in all), shuffled."""
        labels = band_labels(self.config.distance_band_edges)
        k = labels.index(answer)
        order = sorted(range(len(labels)), key=lambda j: (abs(j - k), j))[: self.config.num_choices]
        return self.shuffle([labels[j] for j in order])

    def far_enough(self, d1: float, d2: float) -> bool:
        return far_enough(d1, d2, self.config.distance_margin)

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


def relative_yaw(world_from_cam: np.ndarray, point: np.ndarray) -> float:
    """Horizontal angle (degrees, -180..180) of a world point from a camera's heading; positive = left
    (counter-clockwise seen from above)."""
    fwd = np.asarray(world_from_cam)[:3, 2]
    eye = np.asarray(world_from_cam)[:3, 3]
    d = np.asarray(point, np.float64) - eye
    ang = np.degrees(np.arctan2(d[1], d[0]) - np.arctan2(fwd[1], fwd[0]))
    return float((ang + 180.0) % 360.0 - 180.0)


def band_labels(edges: tuple[float, ...]) -> list[str]:
    """Labels of the distance bands between ``edges`` (m): 'less than 0.5 m', '0.5-1.0 m', ..., 'more than 6.0 m'."""
    out = [f"less than {edges[0]:.1f} m"]
    out += [f"{a:.1f}-{b:.1f} m" for a, b in zip(edges[:-1], edges[1:], strict=True)]
    return out + [f"more than {edges[-1]:.1f} m"]


def distance_band(d: float, edges: tuple[float, ...], margin: float) -> tuple[str, bool]:
    """The band label of distance ``d`` (m) and whether it lies within ``margin`` of a band edge."""
    k = int(np.searchsorted(np.asarray(edges), d, side="right"))
    near = bool(np.min(np.abs(np.asarray(edges) - d)) < margin)
    return band_labels(edges)[k], near


def yaw_sector(angle: float, margin: float) -> tuple[str, bool]:
    """'ahead', 'left', 'behind' or 'right' for a relative yaw (degrees, positive = left), and whether it is
    within ``margin`` of a sector boundary (+-45, +-135 degrees)."""
    a = (angle + 180.0) % 360.0 - 180.0
    near = min(abs(abs(a) - 45.0), abs(abs(a) - 135.0)) < margin
    if abs(a) < 45.0:
        return "ahead", near
    if abs(a) > 135.0:
        return "behind", near
    return ("left" if a > 0 else "right"), near
