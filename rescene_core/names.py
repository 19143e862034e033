"""The one name of an exported object, formed from its instance id and label.

Every export names an object the same way: the scene.glb node, the mesh file ``scene/objects/<name>.glb``,
the USD prim ``/World/Objects/<name>``, the MJCF body (and its ``<name>/visual``, ``<name>/col<k>`` geoms
and meshes, files ``mjcf/meshes/<name>.stl`` and ``<name>_col<k>.stl``), and the physics check's and the
export report's ``node``. A label is free text from a segmenter or a person (``part of a cabinet/wardrobe``,
``crème brûlée jar``, ``3 books``, ``""``); a name must be a file name with no folder in it, a USD prim name
(an identifier: ``[A-Za-z_][A-Za-z0-9_]*``, as ``pxr.Tf.IsValidIdentifier`` checks) and an MJCF name.

The name is ``obj_<id>_<slug>``: accents are dropped from the label (``é`` -> ``e``), every other character
that is not an ASCII letter, digit or underscore becomes ``_`` (spaces, ``/``, ``\\``, dots, letters with no
ASCII form), and the slug is cut to ``MAX_SLUG_CHARS``. A plain label keeps the name it always had
(``chair`` -> ``obj_12_chair``, ``night stand`` -> ``obj_3_night_stand``). A label with no letter or digit
left (``""``, ``"//"``) gives ``obj_<id>``. The ``obj_<id>`` prefix makes a name start with a letter whatever
the label (``3 books`` -> ``obj_7_3_books``), and since the id is unique and ends at the next ``_``, two
objects never share a name, not even on a file system that ignores case.

The label itself is kept verbatim beside the name: scene.json (``label`` and ``node`` per object), the glTF
node's ``extras.label``, the USD prim's ``customData`` ``rescene:label`` (and ``displayName``), and an MJCF
``<custom><text name="rescene:label:<name>">`` element (MJCF has no free attributes; MuJoCo refuses an empty
text, so an empty label has none).
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable

PREFIX = "obj"
"""First part of every object name (so a name starts with a letter whatever the label)."""
MAX_SLUG_CHARS = 64
"""Longest label part of a name (characters): file names stay far below the 255-byte limit of common file
systems, with room for the MJCF's ``_col<k>.stl`` suffixes."""
MJCF_LABEL_TEXT = "rescene:label:"
"""Prefix of the MJCF ``<custom><text>`` element that holds an object's label: ``rescene:label:<name>``."""

_INVALID = re.compile(r"[^A-Za-z0-9_]")


def label_slug(label: str) -> str:
    """The label's part of an object name: accents dropped, every character outside ``[A-Za-z0-9_]``
    replaced by ``_``, at most ``MAX_SLUG_CHARS`` characters."""
    decomposed = unicodedata.normalize("NFKD", label)
    ascii_letters = "".join(c for c in decomposed if not unicodedata.combining(c))
    return _INVALID.sub("_", ascii_letters)[:MAX_SLUG_CHARS]


def node_name(instance: int, label: str) -> str:
    """The name of object ``instance`` with ``label`` in every export (see the module doc)."""
    if int(instance) < 0:
        raise ValueError(f"instance id {instance} is negative: object names need a non-negative id")
    slug = label_slug(label)
    if not any(c.isalnum() for c in slug):
        return f"{PREFIX}_{int(instance)}"
    return f"{PREFIX}_{int(instance)}_{slug}"


def check_unique(objects: Iterable[tuple[int, str]]) -> dict[int, str]:
    """{instance: name} of (instance, label) pairs; raises ValueError when two objects would share a name
    (compared ignoring case, as a case-insensitive file system does), which only a repeated id can cause."""
    names: dict[int, str] = {}
    seen: dict[str, tuple[int, str]] = {}
    for instance, label in objects:
        name = node_name(instance, label)
        key = name.casefold()
        if key in seen:
            other = seen[key]
            raise ValueError(
                f"objects {other[0]} ({other[1]!r}) and {instance} ({label!r}) would both be exported as {name!r}: "
                "instance ids must be unique"
            )
        seen[key] = (int(instance), label)
        names[int(instance)] = name
    return names
