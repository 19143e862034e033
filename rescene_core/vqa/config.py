"""Configuration of embodied VQA generation from an assembled scene.

The paper (Sec. 'Embodied Visual Question Answering', appendix 'VQA Data Generation') names the filters
but gives no numbers for them; the defaults below are this project's choices, except the relation
confidence threshold, which is the scene graph's low-confidence threshold.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from rescene_core.config import SceneGraphConfig


def _low_confidence() -> float:
    return SceneGraphConfig().low_confidence


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
    """Relations with a confidence below this are not asked about (default: SceneGraphConfig.low_confidence)."""
    distance_margin: float = Field(0.15, ge=0.0)
    """Distance comparisons need |d1 - d2| >= this fraction of the larger distance."""
    height_margin: float = Field(0.15, ge=0.0)
    """'Which is higher' needs the centre heights to differ by at least this (m)."""
    bearing_margin_deg: float = Field(8.0, ge=0.0)
    """Left/right questions need the two objects' bearings from the camera to differ by this (degrees)."""

    views: int = Field(6, ge=0)
    """Viewpoints to sample and render; 0 generates only viewpoint-free questions."""
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
