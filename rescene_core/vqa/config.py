"""Configuration of embodied VQA generation from an assembled scene.

The paper (Sec. 'Embodied Visual Question Answering', appendix 'VQA Data Generation') names the filters
but gives no numbers for them; the defaults below are this project's choices, except the relation
confidence threshold, which is the scene graph's low-confidence threshold.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from rescene_core.config import SceneGraphConfig


def _low_confidence() -> float:
    return SceneGraphConfig().fusion.low_confidence


class VqaConfig(BaseModel):
    """Templates, ambiguity filters, viewpoint sampling and rendering of the VQA generator."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    seed: int = 0
    """Seed of every random choice (viewpoints, sampling of questions, order of choices)."""
    per_category: int = Field(12, ge=0)
    """Most questions kept per category (sampled with the seed from all unambiguous candidates)."""
    num_choices: int = Field(4, ge=2)
    """Choices of a multiple-choice question (fewer when the scene has too few distinct answers)."""

    min_confidence: float = Field(default_factory=_low_confidence, ge=0.0, le=1.0)
    """Relations with a confidence below this are not asked about (default: SceneGraphConfig.fusion.low_confidence)."""
    distance_margin: float = Field(0.15, ge=0.0)
    """Distance comparisons need |d1 - d2| >= this fraction of the larger distance."""
    height_margin: float = Field(0.15, ge=0.0)
    """'Which is higher' needs the centre heights to differ by at least this (m)."""
    bearing_margin_deg: float = Field(8.0, ge=0.0)
    """Left/right questions need the two objects' bearings from the camera to differ by this (degrees)."""

    distance_band_edges: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
    """Metric distance questions answer with a band between consecutive edges (m; 'less than' the first,
    'more than' the last)."""
    distance_band_margin: float = Field(0.1, ge=0.0)
    """A metric distance within this of a band edge is not asked about (m)."""
    sector_margin_deg: float = Field(10.0, ge=0.0)
    """Direction questions (ahead/left/right/behind, which wall the camera faces) need the direction to be
    at least this far from a sector boundary (degrees)."""
    visibility_margin: float = Field(2.0, ge=1.0)
    """Counting in a view needs every object of the label to cover either >= this times
    ``min_visible_pixels`` or < ``min_visible_pixels`` / this (objects near the threshold are ambiguous)."""

    sampling: Literal["target", "walk"] = "target"
    """How views are taken: 'target' samples one viewpoint per target object; 'walk' is the paper's agent,
    a capture after every discrete action of an egocentric walk."""
    views: int = Field(6, ge=0)
    """Viewpoints to sample and render with sampling 'target'; 0 generates only viewpoint-free questions."""
    walks: int = Field(1, ge=0)
    """Walks of the agent per scene (sampling 'walk')."""
    walk_steps: int = Field(16, ge=1)
    """Discrete actions per walk, a capture after each."""
    walk_eye_height: float = Field(1.5, gt=0.0)
    """The agent's fixed eye height above the floor (m)."""
    walk_step_m: float = Field(0.5, gt=0.0)
    """Length of a forward move (m)."""
    walk_turn_deg: float = Field(30.0, gt=0.0)
    """Yaw change of a turn (degrees)."""
    walk_look_deg: float = Field(15.0, gt=0.0)
    """Pitch change of a look up/down (degrees)."""
    walk_look_max_deg: float = Field(30.0, ge=0.0, lt=89.0)
    """Largest pitch up or down (degrees)."""
    walk_action_probs: tuple[float, float, float, float, float] = (0.4, 0.2, 0.2, 0.1, 0.1)
    """Probabilities of forward, turn left, turn right, look up, look down."""
    eye_height_min: float = 1.2
    """Lowest camera height above the floor (m)."""
    eye_height_max: float = 1.7
    """Highest camera height above the floor (m)."""
    wall_clearance: float = Field(0.3, ge=0.0)
    """A viewpoint keeps at least this distance to the floor polygon's boundary (m)."""
    object_clearance: float = Field(0.25, ge=0.0)
    """A viewpoint keeps at least this horizontal distance to every object's footprint (m)."""
    view_distance_min: float = Field(0.8, ge=0.0)
    """Least horizontal distance from a viewpoint to its target object's centre (m)."""
    view_distance_max: float = Field(6.0, gt=0.0)
    """Largest horizontal distance from a viewpoint to its target object's centre (m)."""
    max_view_attempts: int = Field(200, ge=1)
    """Position samples tried per viewpoint before the target is given up."""
    min_visible_pixels: int = Field(60, ge=1)
    """An object is visible in a view when its id covers at least this many pixels (paper: 'a minimal pixel
    threshold')."""
    image_width: int = Field(320, ge=16)
    """Rendered view width (pixels)."""
    image_height: int = Field(240, ge=16)
    """Rendered view height (pixels)."""
    hfov_deg: float = Field(75.0, gt=10.0, lt=170.0)
    """Horizontal field of view of the rendered views (degrees)."""
    light_below_ceiling: float = 0.2
    """The ceiling-centred light hangs this far below the ceiling (m)."""
    default_ceiling_height: float = 2.5
    """Ceiling height used when the room shell does not know it (m)."""
