"""Instance ids, the relation and root vocabularies, the stage names, and how a parent is written."""

from __future__ import annotations

import enum
from typing import NewType

InstanceId = NewType("InstanceId", int)
"""Canonical instance id taken from the capture's panoptic output (> 0; 0 means 'no instance')."""


class Relation(enum.StrEnum):
    """Relation of a child to its parent in the scene graph."""

    RESTS_ON = "rests-on"
    MOUNTS_ON = "mounts-on"


class Root(enum.StrEnum):
    """Structural roots of the scene graph. Which wall is meant is resolved later, geometrically."""

    FLOOR = "floor"
    WALL = "wall"


class Stage(enum.StrEnum):
    """The stages of the pipeline, by the one name used everywhere: task names, run-log segments,
    ``Missing.stage``, manifest stage counts, fault injection and the library's ``STAGE`` constants.

    Earlier names are accepted when reading (``"hierview"`` is ``VIEW``, ``"assembly"`` is ``ATTACHMENT``).
    """

    VALIDATE = "validate"
    SHELL = "shell"
    VIEW = "view"
    KEYFRAMES = "keyframes"
    ASSET = "asset"
    REGISTRATION = "registration"
    RELATIONS = "relations"
    FUSION = "fusion"
    SNAPSHOT = "snapshot"
    ATTACHMENT = "attachment"
    EXPORT = "export"
    SIMCHECK = "simcheck"
    EVALUATION = "evaluation"

    @classmethod
    def _missing_(cls, value: object) -> Stage | None:
        return _STAGE_ALIASES.get(str(value))


_STAGE_ALIASES = {"hierview": Stage.VIEW, "assembly": Stage.ATTACHMENT}


Parent = InstanceId | Root
"""A parent is another instance or a structural root."""

STRUCTURAL_LABELS = frozenset({"floor", "wall", "ceiling"})


def parent_to_json(parent: Parent) -> int | str:
    return parent.value if isinstance(parent, Root) else int(parent)


def _same_parent(a: Parent, b: Parent) -> bool:
    """Whether two parents are the same root, or the same instance."""
    if isinstance(a, Root) or isinstance(b, Root):
        return a is b
    return int(a) == int(b)


def parent_from_json(value: int | str) -> Parent:
    if isinstance(value, str):
        try:
            return Root(value)
        except ValueError:
            if value.isdigit():
                return InstanceId(int(value))
            raise
    return InstanceId(int(value))
