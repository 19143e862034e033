"""Collision geometry for the simulation exports: the convex decomposition of each mesh (CoACD in a worker
process, cached by content; ``decompose``), and the edits the layout makes to those pieces (``edits``:
completions as boards and bases, hollow shells, seats carved under children, footings, neighbours cut
apart, walls cut at their planes), on the primitives of ``pieces``. The file formats that carry them are
in ``rescene_core.export``."""

from rescene_core.colliders.decompose import Decomposition, DecompositionSettings, decompose, decompose_all
from rescene_core.colliders.edits import ColliderEdits, edit_colliders
from rescene_core.colliders.hollow import find_hollow, hollow_shell
from rescene_core.colliders.pieces import Piece, PlacedMesh, Placement, placement

__all__ = [
    "ColliderEdits",
    "Decomposition",
    "DecompositionSettings",
    "Piece",
    "PlacedMesh",
    "Placement",
    "decompose",
    "decompose_all",
    "edit_colliders",
    "find_hollow",
    "hollow_shell",
    "placement",
]
