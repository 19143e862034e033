"""The question records and vocabulary of the VQA generator: categories, filter reasons, items.

Compass names: world +y is north and +x is east; a wall is named by the direction from the room towards
it (the opposite of its inward normal).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rescene_core.records import Edge, WallPlane


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
    NEAR_BAND_EDGE = "near_band_edge"
    NEAR_SECTOR_BOUNDARY = "near_sector_boundary"
    NEAR_VISIBILITY_THRESHOLD = "near_visibility_threshold"
    MISSING_GRAPH = "missing_graph"
    MISSING_INSTANCE = "missing_instance"


class TaskType(enum.StrEnum):
    """The four task types of the paper's Table 4, plus recognition (the appendix's category that Table 4
    does not report)."""

    OBJECT_COUNT = "object_count"
    DISTANCE_JUDGEMENT = "distance_judgement"
    RELATION_REASONING = "relation_reasoning"
    VIEWPOINT_ESTIMATION = "viewpoint_estimation"
    RECOGNITION = "recognition"


TABLE4_TASKS = (
    TaskType.OBJECT_COUNT,
    TaskType.DISTANCE_JUDGEMENT,
    TaskType.RELATION_REASONING,
    TaskType.VIEWPOINT_ESTIMATION,
)
"""The columns of the paper's Table 4 (its 'Avg' is over these)."""

TEMPLATE_TASKS: dict[str, TaskType] = {
    "count": TaskType.OBJECT_COUNT,
    "count_in_view": TaskType.OBJECT_COUNT,
    "label_at_position": TaskType.RECOGNITION,
    "label_at_view_centre": TaskType.RECOGNITION,
    "closer_to_camera": TaskType.DISTANCE_JUDGEMENT,
    "closer_to_object": TaskType.DISTANCE_JUDGEMENT,
    "distance_between": TaskType.DISTANCE_JUDGEMENT,
    "distance_to_camera": TaskType.DISTANCE_JUDGEMENT,
    "left_right_in_view": TaskType.RELATION_REASONING,
    "higher": TaskType.RELATION_REASONING,
    "rests_on": TaskType.RELATION_REASONING,
    "what_rests_on": TaskType.RELATION_REASONING,
    "which_wall": TaskType.RELATION_REASONING,
    "what_on_wall": TaskType.RELATION_REASONING,
    "mounted_on_a_wall": TaskType.RELATION_REASONING,
    "mounted_on_object": TaskType.RELATION_REASONING,
    "same_support": TaskType.RELATION_REASONING,
    "support_of_support": TaskType.RELATION_REASONING,
    "rests_on_nearest": TaskType.RELATION_REASONING,
    "rests_on_neighbour_in_view": TaskType.RELATION_REASONING,
    "facing_wall": TaskType.VIEWPOINT_ESTIMATION,
    "object_direction": TaskType.VIEWPOINT_ESTIMATION,
    "nearest_to_camera": TaskType.VIEWPOINT_ESTIMATION,
    "behind_camera": TaskType.VIEWPOINT_ESTIMATION,
}
"""The Table 4 task type of every template."""


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

    @property
    def task(self) -> TaskType:
        """The Table 4 task type of the item's template."""
        return TEMPLATE_TASKS[self.template]

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "category": self.category.value,
            "task": self.task.value,
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

    def task_counts(self) -> dict[str, int]:
        out = {t.value: 0 for t in TaskType}
        for item in self.items:
            out[item.task.value] += 1
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


def edge_json(e: Edge) -> dict[str, Any]:
    """An edge as provenance JSON (child, relation, parent, confidence, wall id)."""
    return {
        "child": int(e.child),
        "relation": e.relation.value,
        "parent": e.to_json()["parent"],
        "confidence": round(float(e.confidence), 4),
        "wall_id": e.wall_id,
    }


def fmt_point(v: np.ndarray) -> str:
    """A point as '(x, y, z)' with one decimal (m)."""
    return "(" + ", ".join(f"{x:.1f}" for x in v) + ")"
