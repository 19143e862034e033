"""The relation prompt, its strict JSON schema, the retry prompt and the A/B re-ranking prompt.

The answer format is the paper's (Appendix "Key-Frame Selection and Scene Graph Prompting"):

    {"objects": [{"id": <display id>, "category": "<fixed name>", "relation": "rests-on|mounts-on",
                  "parent": <display id> | "floor" | "wall"}]}
"""

from __future__ import annotations

import json
from typing import Any

from rescene_core.records import Relation, Root

RELATIONS = tuple(r.value for r in Relation)
ROOTS = tuple(r.value for r in Root)

SYSTEM_PROMPT = (
    "You are a careful annotator of indoor scenes. You look at one photo of a room in which every object "
    "of interest is marked with a numeric ID drawn inside it, and you describe how each marked object is "
    "physically held in place. You answer with strict JSON only, no prose."
)


def relation_schema(display_ids: list[int]) -> dict[str, Any]:
    """JSON schema of an answer for a frame showing ``display_ids`` (sent as response_format)."""
    ids = sorted(int(i) for i in display_ids)
    return {
        "type": "object",
        "properties": {
            "objects": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "id": {"type": "integer", "enum": ids},
                        "category": {"type": "string"},
                        "relation": {"type": "string", "enum": list(RELATIONS)},
                        "parent": {
                            "anyOf": [{"type": "integer", "enum": ids}, {"type": "string", "enum": list(ROOTS)}]
                        },
                    },
                    "required": ["id", "category", "relation", "parent"],
                    "additionalProperties": False,
                },
            }
        },
        "required": ["objects"],
        "additionalProperties": False,
    }


def relation_prompt(categories: dict[int, str]) -> str:
    """The user prompt for one frame; ``categories`` maps display id -> the capture's category label."""
    listing = "\n".join(f"  {d}: {categories[d]}" for d in sorted(categories))
    return (
        "The image shows a room. These objects are marked with their ID, drawn inside each object:\n"
        f"{listing}\n\n"
        "For EVERY marked ID give exactly one entry with:\n"
        '  "id": the ID;\n'
        '  "category": the category exactly as listed above (do not change it);\n'
        '  "relation": "rests-on" if the object is supported from below by its parent (gravity holds it on a '
        'surface), or "mounts-on" if it is attached to the side of its parent (hung or fixed on it);\n'
        '  "parent": the ID of another marked object, or "floor" or "wall" (floor and wall are not marked).\n'
        "An object cannot be its own parent and the parents must not form a loop.\n"
        'Answer with JSON only: {"objects": [{"id": 1, "category": "...", "relation": "rests-on", '
        '"parent": "floor"}, ...]}'
    )


def retry_prompt(base_prompt: str, previous: str | None, errors: list[str]) -> str:
    """The prompt for a validation retry: the original request, the previous answer and its errors."""
    shown = previous if previous is not None else "(no answer)"
    problems = "\n".join(f"- {e}" for e in errors)
    return (
        f"{base_prompt}\n\nYour previous answer was:\n{shown}\n\n"
        f"It was rejected for these reasons:\n{problems}\n\n"
        "Answer again with corrected, complete JSON only."
    )


AB_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {"answer": {"type": "string", "enum": ["A", "B"]}},
    "required": ["answer"],
    "additionalProperties": False,
}


def describe_parent(parent: int | str, categories: dict[int, str]) -> str:
    """'the floor', 'a wall' or 'object 3 (table)' for display parents."""
    if parent == Root.FLOOR.value:
        return "the floor"
    if parent == Root.WALL.value:
        return "a wall"
    return f"object {parent} ({categories.get(int(parent), 'object')})"


def ab_prompt(
    child: int, categories: dict[int, str], option_a: tuple[str, int | str], option_b: tuple[str, int | str]
) -> str:
    """A/B prompt for one uncertain edge: which of two (relation, parent) options holds for ``child``."""

    def text(option: tuple[str, int | str]) -> str:
        relation, parent = option
        verb = "rests on" if relation == Relation.RESTS_ON.value else "is mounted on"
        return f"object {child} ({categories.get(child, 'object')}) {verb} {describe_parent(parent, categories)}"

    return (
        "The image shows a room with objects marked by numeric IDs.\n"
        f"Which statement is true?\n  A: {text(option_a)}\n  B: {text(option_b)}\n"
        'Answer with JSON only: {"answer": "A"} or {"answer": "B"}.'
    )


def answer_json(entries: list[dict[str, Any]]) -> str:
    """Serialise an answer in the prompt's format (used by the weight-free backend)."""
    return json.dumps({"objects": entries})
