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
