"""Presets of the synthetic capture generator: scene size, camera walk, and the panoptic error dials."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class SynthPreset(BaseModel):
    """Everything that shapes one synthetic capture besides the seed. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    name: str
    """Preset name (recorded in the capture's attrs)."""
    # room and furniture
    room_shapes: tuple[str, ...] = ("rect", "L")
    """Floor shapes to draw from: 'rect' and/or 'L'."""
    room_width: tuple[float, float] = (4.0, 5.5)
    """Range of the room's extent along x (m)."""
    room_depth: tuple[float, float] = (3.5, 4.8)
    """Range of the room's extent along y (m)."""
    ceiling: tuple[float, float] = (2.4, 3.0)
    """Range of the wall height (m)."""
    objects: tuple[int, int] = (20, 25)
    """Fewest and most objects placed (the generator stops at a number drawn from this range)."""
    program: str = "furnished"
    """Which placement program runs: 'tiny' (desk corner), 'furnished', 'cluttered' (more and stacked),
    'egocentric' (a kitchen with an island and a living corner, ``capture.synth.kitchen``)."""
    contact_gap: float = 0.001
    """Gap left between touching surfaces (m): resting objects, backs against walls."""
    furniture_clearance: float = 0.04
    """Smallest gap between two pieces of floor furniture (m)."""
    # camera walk
    width: int = 640
    """Image width (pixels)."""
    height: int = 480
    """Image height (pixels)."""
    hfov_deg: float = 68.0
    """Horizontal field of view (deg)."""
    frames: int = 120
    """Number of frames."""
    closeup_fraction: float = 0.15
    """Fraction of frames that are close-ups of large objects (crop them)."""
    distant_fraction: float = 0.08
    """Fraction of frames that are distant views from the room's corners."""
    walk_height: tuple[float, float] = (1.3, 1.7)
    """Camera height range of the walk (m)."""
    closeup_distance: tuple[float, float] = (0.35, 0.7)
    """Distance of close-up cameras from the object surface they look at (m)."""
    camera: str = "walk"
    """Which camera walk: 'walk' (the loop above, close-ups, distant views) or 'head' (a head-mounted camera
    at ``walk_height`` walking one side of the room, looking down at its work surfaces; egocentric program)."""
    head_pitch_deg: tuple[float, float] = (20.0, 60.0)
    """'head' walk: range of the camera's pitch below the horizon (deg)."""
    head_roll_deg: float = 15.0
    """'head' walk: largest roll of the camera about its viewing axis (deg)."""
    head_yaw_deg: float = 45.0
    """'head' walk: largest turn of the view away from facing the kitchen wall (deg); the wall behind is never seen."""
    # rendering
    shadows: bool = True
    """Cast shadows from the ceiling light."""
    shadow_stride: int = 2
    """Shadow rays at every n-th pixel in x and y (see ``Shading.shadow_stride``)."""
    rgb_noise: float = 1.5
    """Standard deviation of the image sensor noise (8-bit levels)."""
    threads: int = 2
    """Frames rendered concurrently (results do not depend on it)."""
    # panoptic errors (the dials)
    depth_noise_base: float = 0.002
    """Depth noise standard deviation at 0 m (m)."""
    depth_noise_quadratic: float = 0.0015
    """Depth noise growth: sigma(z) = base + quadratic * z^2 (m / m^2)."""
    depth_dropout: float = 0.01
    """Fraction of pixels whose depth is invalid (0)."""
    mask_boundary_px: int = 2
    """Width of the band around mask boundaries where labels are noisy (pixels at 640 px width)."""
    mask_boundary_prob: float = 0.35
    """Probability that a pixel in the boundary band takes a neighbour's label."""
    drift_frame_prob: float = 0.12
    """Probability that a frame has one mask drifting onto a neighbouring object."""
    drift_px: int = 18
    """How far a drifting mask slides onto its neighbour (pixels at 640 px width)."""
    split_prob: float = 0.08
    """Probability that an object (of at least ``split_min_size``) is split into two instances."""
    split_min_size: float = 0.6
    """Smallest largest-dimension (m) of an object that can be split."""
    miss_small_prob: float = 0.25
    """Probability that a small object (largest dimension below ``small_size``) is missed altogether."""
    small_size: float = 0.3
    """Largest dimension (m) under which an object counts as small."""
    wrong_label_prob: float = 0.06
    """Probability that an object's instance gets a confusable wrong label."""
    # point clouds
    fusion_stride: int = 2
    """Pixel stride when back-projecting masked depth into instance point clouds."""
    object_voxel_ratio: float = 0.014
    """Voxel size of an object's point cloud as a fraction of its bounding-box diagonal."""
    object_voxel_range: tuple[float, float] = (0.006, 0.025)
    """Clamp of the object voxel size (m)."""
    structure_voxel: float = 0.05
    """Voxel size of floor, wall and ceiling point clouds (m)."""
    max_points_per_instance: int = 12000
    """Largest point cloud kept per instance; larger ones are subsampled at random (seeded)."""

    def settings(self) -> dict:
        """The fields as JSON values, for the capture's attrs; the 'head' walk's fields only when it is used
        (so the captures of the presets that predate them keep their exact attrs)."""
        out = self.model_dump(mode="json")
        if self.camera != "head":
            for key in HEAD_FIELDS:
                del out[key]
        return out

    def with_overrides(self, **overrides) -> SynthPreset:
        """A copy with some fields replaced (validated)."""
        return SynthPreset.model_validate({**self.model_dump(), **overrides})


HEAD_FIELDS = ("camera", "head_pitch_deg", "head_roll_deg", "head_yaw_deg")
"""Fields of the head-mounted walk (``SynthPreset.settings`` leaves them out of other walks' attrs)."""

PRESETS: dict[str, SynthPreset] = {
    "tiny": SynthPreset(
        name="tiny",
        room_shapes=("rect",),
        room_width=(3.2, 3.8),
        room_depth=(3.0, 3.4),
        objects=(5, 6),
        program="tiny",
        width=160,
        height=120,
        frames=12,
        closeup_fraction=0.17,
        distant_fraction=0.09,
        shadows=False,
        fusion_stride=1,
        drift_frame_prob=0.2,
        miss_small_prob=0.0,
        split_prob=0.0,
        wrong_label_prob=0.0,
    ),
    "standard": SynthPreset(name="standard"),
    "cluttered": SynthPreset(
        name="cluttered",
        room_width=(5.0, 6.5),
        room_depth=(4.2, 5.5),
        objects=(40, 48),
        program="cluttered",
        frames=150,
        drift_frame_prob=0.18,
        split_prob=0.1,
        miss_small_prob=0.3,
        wrong_label_prob=0.08,
    ),
    "egocentric": SynthPreset(
        name="egocentric",
        room_shapes=("rect",),
        room_width=(5.2, 6.4),
        room_depth=(4.2, 5.2),
        ceiling=(2.5, 2.8),
        objects=(26, 32),
        program="egocentric",
        width=480,
        height=360,
        hfov_deg=80.0,
        frames=72,
        closeup_fraction=0.0,
        distant_fraction=0.0,
        walk_height=(1.5, 1.8),
        camera="head",
        miss_small_prob=0.15,
        small_size=0.2,
    ),
}
"""The named presets: tiny (tests), standard (demo, benchmarks), cluttered (stress), egocentric (a kitchen
walked by a head-mounted camera looking down: partial views, raised supports seen from above)."""


def get_preset(preset: str | SynthPreset, **overrides) -> SynthPreset:
    """The preset named ``preset`` (or the given one) with ``overrides`` applied."""
    if isinstance(preset, SynthPreset):
        base = preset
    else:
        try:
            base = PRESETS[preset]
        except KeyError:
            raise ValueError(f"unknown synth preset {preset!r}; choose one of {', '.join(PRESETS)}") from None
    return base.with_overrides(**overrides) if overrides else base
