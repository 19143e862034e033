"""The attachment solver's section."""

from __future__ import annotations

from typing import Literal

from rescene_core.config.base import _Section


class AttachmentConfig(_Section):
    """Attachment and layout refinement (paper Table 'Default attachment hyperparameters')."""

    contact_gap: float = 0.01
    """Default contact gap (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    wall_collision_margin: float = 0.02
    """Wall collision margin (m): a gap between an object and a wall up to this is contact and is kept.
    Default: the paper's (Table 'Default attachment hyperparameters')."""
    restore_toward_evidence: bool = True
    """After depenetration, step each generated object back toward its registered place as far as its
    contacts, the room and its neighbours allow (``assembly/restore.py``). Default: the project's."""
    wall_contact_gap: float = 0.002
    """Gap (m) a repair leaves between an object and the wall it moves the object onto or back inside of
    (floor-snap footprint step, wall and corner snaps, outside repair): the smallest correction that makes
    contact. With the collision margin as the target every object standing against a wall was put 2 cm off it,
    away from where the capture saw it. Default: the project's."""
    wall_corner_margin: float = 0.05
    """Wall corner margin (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    max_floor_snap: float = 1.40
    """Maximum floor-snap vertical translation (m).
    Default: the paper's (Table 'Default attachment hyperparameters')."""
    max_floor_yaw_deg: float = 15.0
    """Maximum floor yaw rotation (deg). Default: the paper's (Table 'Default attachment hyperparameters')."""
    max_wall_yaw_deg: float = 35.0
    """Maximum wall yaw rotation (deg). Default: the paper's (Table 'Default attachment hyperparameters')."""
    near_wall_distance: float = 0.45
    """Near-wall auto-snap distance (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    auto_wall_snap_translation: float = 1.20
    """Auto wall-snap maximum translation (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    auto_wall_snap_rotation_deg: float = 25.0
    """Auto wall-snap maximum rotation (deg). Default: the paper's (Table 'Default attachment hyperparameters')."""
    cabinet_corner_translation: float = 0.20
    """Cabinet-corner maximum translation (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    depenetration_iterations: int = 8
    """Depenetration iterations. Default: the paper's (Table 'Default attachment hyperparameters')."""
    depenetration_step: float = 0.04
    """Non-wall depenetration step (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    wall_tangent_step: float = 0.02
    """Wall-tangent depenetration step (m). Default: the paper's (Table 'Default attachment hyperparameters')."""
    depenetration_max_fit_drop: float | None = 0.10
    """Generated assets with observed points: a depenetration push may lower the share of the object's
    points on its mesh box's surface (``evidence.surface_fit``) by at most this much below the share at its
    registered pose; a longer push is cut to the longest that keeps to it, and from then on the object's
    partners take the whole separation (a generated table's filled space between its legs would otherwise
    push a chair 0.2 m away from where it was seen). None: pushes are not bounded.
    Default: the project's choice."""
    near_wall_snap: bool = True
    """Run the near-wall snap refinement.
    Default: the paper's (Appendix 'Attachment and Layout Refinement': part of the default pipeline)."""
    bed_wall: bool = True
    """Run the bed-wall refinement.
    Default: the paper's (Appendix 'Attachment and Layout Refinement': part of the default pipeline)."""
    cabinet_corner: bool = True
    """Run the cabinet-corner refinement.
    Default: the paper's (Appendix 'Attachment and Layout Refinement': part of the default pipeline)."""
    dual_attachment: bool = True
    """Run the wall-aware and the floor-only branch and keep one per object.
    Default: the paper's (Appendix 'Attachment and Layout Refinement': part of the default pipeline)."""
    wall_confidence_min: float = 0.60
    """Dual attachment: a group with a wall edge below this confidence keeps the floor-only branch (paper's
    low-confidence threshold).
    Default: the paper's low-confidence threshold (Appendix 'Multi-Frame Fusion Details'), applied here by the project."""
    max_level_tilt_deg: float = 45.0
    """Floor, wall and support snaps level the asset axis nearest the floor normal when tilted at most this (deg).
    Default: the project's choice."""
    floor_yaw_align: bool = False
    """Floor snap also turns the object onto the nearest room axis when within max_floor_yaw_deg.
    Default: the project's choice."""
    wall_normal_weight: float = 0.5
    """Wall resolution: metres of coplanarity residual one radian of normal mismatch costs.
    Default: the project's choice."""
    wall_side_min_gain: float | None = 0.02
    """Generated wall objects with observed points: the wall rule turns the object onto another side than
    its dominant vertical face direction (a horizontal asset axis onto the wall's normal, more than 10 deg
    from it, within max_wall_yaw_deg) when that side, put on the wall, has its mesh box explain at least
    this larger share of the points (``assembly/wall_evidence.py``: marching-cubes bevels outweigh a small shelf's sides).
    None: the face direction alone. Default: the project's choice."""
    wall_points_max_gap: float | None = 0.45
    """A generated object on a ``mounts-on wall`` edge whose observed points come no nearer to its resolved
    wall than this (m, their 5th percentile distance) contradicts the edge: it keeps its registered pose and
    the skip names the reason (a deep wall cabinet seen only from the front is seen about its depth off the
    wall). None: never refused. Default: the project's choice (the paper's near-wall snap distance)."""
    wall_evidence_turn_min_gain: float | None = 0.20
    """Before the rules run, a generated object on a ``mounts-on wall`` edge at least wall_confidence_min
    confident is turned beyond max_wall_yaw_deg onto a side of its mesh when that side, put on the wall its
    points lie on, has its mesh box explain at least this larger share of its points than any side within
    the limit: its registration turned it (a picture slab registered edge-on to its flat points). None:
    never. Default: the project's choice."""
    support_normal_deg: float = 10.0
    """Parent faces whose normal is within this angle of the floor normal are support faces (deg).
    Default: the project's choice."""
    support_level_tolerance: float = 0.01
    """Support faces within this height of each other form one support level (m). Default: the project's choice."""
    max_support_snap: float = 1.40
    """Largest vertical move of an object-support snap (m; the floor-snap limit). Default: the project's choice."""
    support_inner_tolerance: float | None = 0.15
    """Generated parents: a child whose registered bottom lies more than this (m) below the parent's top
    level stands inside the parent, on an inner face (a shelf board) the generated mesh lacks unless it has a
    level within this distance of the child's bottom; without one the support rule is skipped and the child
    stays at its registered height (not lifted onto the top). Shelf boards are 0.25-0.4 m apart, registration
    sinks a child by at most a few centimetres. None: the nearest level of the mesh, or its top, as for exact
    parents (the support contact then passes, on a face 1-2 m from where the child was seen).
    Default: the project's choice."""
    near_wall_min_footprint: float = 0.25
    """Near-wall snap only moves floor objects with at least this footprint area (m^2, 'large furniture').
    Default: the project's choice."""
    containment_tolerance: float = 0.01
    """A footprint this far (m) beyond the floor polygon still counts as inside. Default: the project's choice."""
    max_correction_m: float | None = 0.5
    """Largest horizontal move (m) the attachment gives an object of its own (beyond where its parent's moves
    carry it), over all its corrections, unless it is in collision (depenetration is not bounded); a longer
    move is cut to this length and its operation says so (``bound_clipped``). Vertical contact closure keeps
    its own limits (max_floor_snap, max_support_snap). None: unbounded. The paper is silent.
    Default: the project's choice (an object seen where it stands is not carried across the room)."""
    completion_min_excess: float | None = None
    """Generated assets: a crossing of a wall or of the floor polygon deeper than this (m), with the object's
    centre inside, is read as a completion error and left alone; a shallower one is a pose or size error
    and is repaired like an exact shape's. None (default): every crossing is repaired, so nothing is left
    through a wall (a simulator cannot load a bed through a wall); set it (0.20 was the earlier default)
    for a generator whose completions are much deeper than its objects. Default: the project's choice."""
    contact_closure_min_confidence: float = 0.60
    """Edges at least this confident get their contact (floor, support face, wall plane) closed in full
    after the confidence-scaled update, and a wall edge its rotation onto the wall too; below it the contact
    is scaled by omega like the rest (the paper's low-confidence threshold).
    Default: the paper's low-confidence threshold (Appendix 'Multi-Frame Fusion Details'), applied here by the project."""
    trim_completions: bool = True
    """Cut a generated asset's mesh where it reaches through the floor or a wall beyond its observed points
    (``assembly/trim.py``), instead of moving the whole object off its points to repair the crossing.
    Default: the project's choice."""
    floor_trust_min_confidence: float | None = 0.30
    """A ``rests-on floor`` edge below ``contact_closure_min_confidence`` but at least this confident is
    trusted in full (its contact closed, a base added where the mesh lacks its lower part) when no other
    object lies beneath the child: an object rests on something, and the floor is all there is under it.
    Below it the edge is scaled by omega (a box fused at 0.05 onto the floor, seen 0.74 m up, is more likely
    on an object the capture missed). None: never. Default: the project's choice."""
    amodal_top_band_m: float | None = 0.10
    """An object resting on the floor whose observed points all lie within this (m) of its highest point (the
    lowest 1 % aside) was seen only from above (a kitchen island from a head-mounted camera): its base spans
    its mesh's whole footprint, from the floor up to its lowest observed point, an amodal block instead of a
    slab on a stem. None: bases only under what the points show. Default: the project's choice."""
    amodal_min_height_m: float = 0.30
    """... when that lowest observed point is at least this high (m) above the floor: below it the gap is
    the mesh's own (a rug, a low tray), not an unseen body. Default: the project's choice."""
    bed_labels: tuple[str, ...] = ("bed",)
    """Labels the bed-wall refinement applies to. Default: the project's choice."""
    cabinet_labels: tuple[str, ...] = ("cabinet", "wardrobe", "dresser", "bookshelf", "bookcase", "shelf")
    """Labels the cabinet-corner refinement applies to. Default: the project's choice."""
    stop_after: Literal["relations", "repair", "full"] = "full"
    """Last stage run: relational layer only, + room/wall repair, or full (+ depenetration).
    Default: the project's choice."""
