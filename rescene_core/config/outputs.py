"""Sections of what a run writes: the VQA generator, the scene exports, the physics check."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from rescene_core.config.base import _Section
from rescene_core.config.scenegraph import FusionConfig


def _low_confidence() -> float:
    return FusionConfig().low_confidence


class VqaConfig(_Section):
    """Templates, ambiguity filters, viewpoint sampling and rendering of the VQA generator (paper Sec.
    'Embodied Visual Question Answering', appendix 'VQA Data Generation'). The paper names the filters but
    gives no numbers for them; the defaults are the project's choices, except the relation confidence
    threshold, which is the scene graph's low-confidence threshold."""

    seed: int = 0
    """Seed of every random choice (viewpoints, sampling of questions, order of choices).
    Default: the project's choice."""
    per_category: int = Field(default=12, ge=0)
    """Most questions kept per category (sampled with the seed from all unambiguous candidates).
    Default: the project's choice."""
    num_choices: int = Field(default=4, ge=2)
    """Choices of a multiple-choice question (fewer when the scene has too few distinct answers).
    Default: the project's choice."""

    min_confidence: float = Field(default_factory=_low_confidence, ge=0.0, le=1.0)
    """Relations with a confidence below this are not asked about (default: SceneGraphConfig.fusion.low_confidence).
    Default: the paper's low-confidence threshold (Appendix 'Multi-Frame Fusion Details'), applied here by the project."""
    distance_margin: float = Field(default=0.15, ge=0.0)
    """Distance comparisons need |d1 - d2| >= this fraction of the larger distance. Default: the project's choice."""
    height_margin: float = Field(default=0.15, ge=0.0)
    """'Which is higher' needs the centre heights to differ by at least this (m). Default: the project's choice."""
    bearing_margin_deg: float = Field(default=8.0, ge=0.0)
    """Left/right questions need the two objects' bearings from the camera to differ by this (degrees).
    Default: the project's choice."""

    distance_band_edges: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
    """Metric distance questions answer with a band between consecutive edges (m; 'less than' the first,
    'more than' the last). Default: the project's choice."""
    distance_band_margin: float = Field(default=0.1, ge=0.0)
    """A metric distance within this of a band edge is not asked about (m). Default: the project's choice."""
    sector_margin_deg: float = Field(default=10.0, ge=0.0)
    """Direction questions (ahead/left/right/behind, which wall the camera faces) need the direction to be
    at least this far from a sector boundary (degrees). Default: the project's choice."""
    visibility_margin: float = Field(default=2.0, ge=1.0)
    """Counting in a view needs every object of the label to cover either >= this times
    ``min_visible_pixels`` or < ``min_visible_pixels`` / this (objects near the threshold are ambiguous).
    Default: the project's choice."""

    sampling: Literal["target", "walk"] = "target"
    """How views are taken: 'target' samples one viewpoint per target object; 'walk' is the paper's agent,
    a capture after every discrete action of an egocentric walk. Default: the project's choice."""
    views: int = Field(default=6, ge=0)
    """Viewpoints to sample and render with sampling 'target'; 0 generates only viewpoint-free questions.
    Default: the project's choice."""
    walks: int = Field(default=1, ge=0)
    """Walks of the agent per scene (sampling 'walk'). Default: the project's choice."""
    walk_steps: int = Field(default=16, ge=1)
    """Discrete actions per walk, a capture after each. Default: the project's choice."""
    walk_eye_height: float = Field(default=1.5, gt=0.0)
    """The agent's fixed eye height above the floor (m). Default: the project's choice."""
    walk_step_m: float = Field(default=0.5, gt=0.0)
    """Length of a forward move (m). Default: the project's choice."""
    walk_turn_deg: float = Field(default=30.0, gt=0.0)
    """Yaw change of a turn (degrees). Default: the project's choice."""
    walk_look_deg: float = Field(default=15.0, gt=0.0)
    """Pitch change of a look up/down (degrees). Default: the project's choice."""
    walk_look_max_deg: float = Field(default=30.0, ge=0.0, lt=89.0)
    """Largest pitch up or down (degrees). Default: the project's choice."""
    walk_action_probs: tuple[float, float, float, float, float] = (0.4, 0.2, 0.2, 0.1, 0.1)
    """Probabilities of forward, turn left, turn right, look up, look down. Default: the project's choice."""
    eye_height_min: float = 1.2
    """Lowest camera height above the floor (m). Default: the project's choice."""
    eye_height_max: float = 1.7
    """Highest camera height above the floor (m). Default: the project's choice."""
    wall_clearance: float = Field(default=0.3, ge=0.0)
    """A viewpoint keeps at least this distance to the floor polygon's boundary (m). Default: the project's choice."""
    object_clearance: float = Field(default=0.25, ge=0.0)
    """A viewpoint keeps at least this horizontal distance to every object's footprint (m).
    Default: the project's choice."""
    view_distance_min: float = Field(default=0.8, ge=0.0)
    """Least horizontal distance from a viewpoint to its target object's centre (m). Default: the project's choice."""
    view_distance_max: float = Field(default=6.0, gt=0.0)
    """Largest horizontal distance from a viewpoint to its target object's centre (m). Default: the project's choice."""
    max_view_attempts: int = Field(default=200, ge=1)
    """Position samples tried per viewpoint before the target is given up. Default: the project's choice."""
    min_visible_pixels: int = Field(default=60, ge=1)
    """An object is visible in a view when its id covers at least this many pixels (paper: 'a minimal pixel
    threshold'). Default: the project's choice."""
    image_width: int = Field(default=320, ge=16)
    """Rendered view width (pixels). Default: the project's choice."""
    image_height: int = Field(default=240, ge=16)
    """Rendered view height (pixels). Default: the project's choice."""
    hfov_deg: float = Field(default=75.0, gt=10.0, lt=170.0)
    """Horizontal field of view of the rendered views (degrees). Default: the project's choice."""
    light_below_ceiling: float = 0.2
    """The ceiling-centred light hangs this far below the ceiling (m). Default: the project's choice."""
    default_ceiling_height: float = 2.5
    """Ceiling height used when the room shell does not know it (m). Default: the project's choice."""


class ExportConfig(_Section):
    """How the room shell is turned into geometry for viewing (objects are exported as they are)."""

    wall_height: float = 2.5
    """Height of the exported walls when the shell has no ceiling height (m). Default: the project's choice."""
    wall_thickness: float = 0.05
    """Thickness of the exported wall slabs, extruded outwards from the wall plane (m).
    Default: the project's choice."""
    floor_thickness: float = 0.02
    """Thickness of the exported floor slab, extruded downwards from the floor plane (m).
    Default: the project's choice."""
    points_per_m2: float = 4000.0
    """Surface samples per square metre of placed mesh in ``scene/points.zarr``. Default: the project's choice."""
    min_points_per_object: int = 200
    """Fewest samples of one object in ``scene/points.zarr``. Default: the project's choice."""
    max_points_per_object: int = 20000
    """Most samples of one object in ``scene/points.zarr``. Default: the project's choice."""
    simulation: bool = True
    """Also write the simulation exports: MJCF, USD and export_report.json (rescene_core/export/simulation.py).
    Default: the project's choice."""
    usd_binary: bool = False
    """Write the USD stage as binary ``scene.usdc`` instead of text ``scene.usda``. Default: the project's choice."""
    physics_table: str | None = None
    """JSON file of per-category density and friction replacing built-in entries (export/physics_tables.py).
    Default: the project's choice."""
    coacd_threshold: float = 0.05
    """CoACD concavity threshold of the convex decomposition (lower: more, tighter pieces).
    Default: the project's choice."""
    coacd_max_pieces: int = 12
    """Most convex collision pieces per object. Default: the project's choice."""
    coacd_max_faces: int = 2000
    """Meshes with more faces are simplified (quadric decimation) to this many before CoACD.
    Default: the project's choice."""
    coacd_timeout_s: float = 180.0
    """Time limit of one object's CoACD run (s); past it the object gets its convex hull.
    Default: the project's choice."""
    decomposition_workers: int = 2
    """CoACD processes running at once. Default: the project's choice."""
    structure_labels: tuple[str, ...] = ("", "object", "unknown", "counter", "countertop", "kitchen counter", "worktop")
    """Labels (any case) of objects that may be built-in structure, fixed to the world when they rest on the
    floor backed onto a wall with a top at counter height (export/structure.py): built-in names and those of a
    label-free segmentation; an empty tuple fixes nothing. Default: the project's choice."""
    structure_top_height_m: tuple[float, float] = (0.6, 1.2)
    """Height range (m above the floor) of the top of built-in structure (counters, fitted shelf units).
    Default: the project's choice."""
    structure_wall_gap_m: float = 0.05
    """Built-in structure comes this close (m) to an observed wall's plane. Default: the project's choice."""
    structure_min_length_m: float = 1.0
    """... along at least this much (m) of the wall. Default: the project's choice."""
    hull_below_m: float | None = 0.15
    """An object whose largest dimension (m, as placed) is under this gets its convex hull as its collider,
    no CoACD (cups, jars and bowls took 45-95 s of CoACD each on an egocentric kitchen); None: CoACD for all.
    Default: the project's choice."""
    decomposition_cache: str | None = None
    """Directory of cached decompositions (default $RESCENE_CACHE_DIR/convex or ~/.cache/rescene/convex).
    Default: the project's choice."""


class SimcheckConfig(_Section):
    """Settings of the physics check (not in the paper: the project's choices)."""

    seconds: float = 2.0
    """Simulated time under gravity (s). Default: the project's choice."""
    stable_translation: float = 0.02
    """Largest centre-of-mass drift of a stable object (m). Default: the project's choice."""
    stable_rotation_deg: float = 5.0
    """Largest rotation of a stable object (deg). Default: the project's choice."""
    escape_margin: float = 0.1
    """How far outside the floor polygon an object's centre may end before it counts as escaped (m).
    Default: the project's choice."""
    shake: bool = False
    """Shake the room horizontally during the first ``shake_seconds``. Default: the project's choice."""
    shake_seconds: float = 1.0
    """How long the shake lasts (s); the rest of ``seconds`` is settling. Default: the project's choice."""
    shake_accel: float = 3.0
    """Peak horizontal acceleration of the shake (m/s^2). Default: the project's choice."""
    shake_hz: tuple[float, float] = (2.0, 5.0)
    """Frequencies of the two sinusoids of the shake (Hz). Default: the project's choice."""
    seed: int = 0
    """Seed of the shake's phases and directions. Default: the project's choice."""
    newton: bool = False
    """Also check scene/scene.usda in Newton, the second engine (the ``newton`` extra), in the same stage:
    sim/simcheck-newton.json, with the objects where the engines disagree. Off by default: it adds about as
    much time as the MuJoCo check. Default: the project's choice."""
