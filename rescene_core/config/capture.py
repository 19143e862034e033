"""Sections of the stages that read the capture as it is: the room shell, HierView view selection, key frames."""

from __future__ import annotations

from typing import Literal

from rescene_core.config.base import _Section


class ShellConfig(_Section):
    """Room-shell estimation from structural instances or from all points."""

    ransac_distance: float = 0.03
    """RANSAC inlier distance for floor and wall planes (m). Default: the project's choice."""
    min_wall_points: int = 200
    """Fewest inlier points for a wall plane to be kept. Default: the project's choice."""
    max_walls: int = 12
    """Most wall planes extracted. Default: the project's choice."""
    vertical_tolerance_deg: float = 10.0
    """Largest tilt of a wall normal from horizontal (deg). Default: the project's choice."""
    sample_voxel: float = 0.02
    """Voxel size the points are thinned to before plane fitting (m). Default: the project's choice."""
    floor_min_fraction: float = 0.2
    """Without floor labels: the floor is the lowest height bin holding at least this fraction of the densest bin.
    Default: the project's choice."""
    wall_max_outside_fraction: float = 0.02
    """Without wall labels: a vertical plane is a wall only if at most this fraction of points lies behind it.
    Default: the project's choice."""
    wall_min_height: float = 1.0
    """Without wall labels: least vertical extent of a wall plane's inliers (m). Default: the project's choice."""
    merge_angle_deg: float = 10.0
    """Wall planes closer than this angle and merge_distance in offset are merged (deg).
    Default: the project's choice."""
    merge_distance: float = 0.2
    """Parallel wall planes closer than this, with overlapping segments, are one wall (noisy depth splits a
    wall into slabs) (m). Default: the project's choice."""
    wall_shadow_overlap: float = 0.5
    """A wall plane more than merge_distance in front of a parallel wall, overlapping it along the wall by
    more than this fraction of the shorter segment, is a furniture face, not the room's boundary (dropped).
    Default: the project's choice."""
    wall_refine_band: float = 0.15
    """Half-width of the slab a wall plane is refitted to (median offset, line fit of its footprint) (m).
    Default: the project's choice."""
    wall_refine_iterations: int = 3
    """Refits of a wall plane to its slab. Default: the project's choice."""
    polygon_snap_distance: float = 0.3
    """Wall lines this far outside the floor points' outline still bound the floor polygon (m).
    Default: the project's choice."""
    polygon_cell_min_coverage: float = 0.5
    """A cell of the wall-line arrangement is floor when the floor outline covers at least this fraction.
    Default: the project's choice."""
    polygon_sliver: float = 0.05
    """Opening radius of the floor polygon: spikes and slivers narrower than twice this go (m).
    Default: the project's choice."""
    polygon_concave_ratio: float = 1.0
    """shapely concave_hull ratio of the floor outline before walls cut it (1 = convex hull; lower follows
    holes that furniture leaves in the floor points). Default: the project's choice."""
    polygon_simplify: float = 0.01
    """Douglas-Peucker tolerance of the floor polygon (m). Default: the project's choice."""
    ransac_iterations: int = 1000
    """RANSAC iterations per plane. Default: the project's choice."""
    seed: int = 0
    """Seed of the RANSAC plane fits. Default: the project's choice."""


class HierViewConfig(_Section):
    """HierView view selection (paper Table 'Default HierView hyperparameters')."""

    method: Literal["hierview", "largest_mask", "completeness_only"] = "hierview"
    """Selection method: HierView, or the largest-mask / completeness-only baselines of the paper.
    Default: the paper's method."""
    min_mask_area: int = 100
    """a_min: minimum mask pixel count for a candidate view (pixels).
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    min_bbox_ratio: float = 0.01
    """b_min: minimum mask-bounding-box area over image area.
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    semantic_backend: Literal["clip", "appearance", "none"] = "appearance"
    """Semantic scorer: open_clip ViT-B/32, a weight-free appearance-consistency scorer, or none.
    Default: the project's choice."""
    semantic_fallback: Literal["appearance", "none"] = "appearance"
    """Scorer used when the CLIP weights cannot be found (the log and report say so). Default: the project's choice."""
    tau_s: float = 0.12
    """tau_s: semantic probability threshold (paper Table A1).
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    semantic_rank_keep: int = 3
    """Candidates of semantic rank <= this are kept regardless of tau_s.
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    semantic_min_keep: int = 2
    """Keep at least this many candidates after semantic filtering, when available.
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    max_points: int = 30000
    """Most instance points projected for the completeness ranking.
    Default: the paper's (Table 'Default HierView hyperparameters')."""
    clip_model: str = "ViT-B-32"
    """open_clip model name (paper: ViT-B/32). Default: the paper's (Table 'Default HierView hyperparameters')."""
    clip_weights: str | None = None
    """Local path to CLIP weights; RESCENE_CLIP_WEIGHTS is read when unset. Never downloaded.
    Default: the project's choice."""
    clip_batch_size: int = 64
    """Crops per CLIP forward pass. Default: the project's choice."""
    clip_prompt: str = "a photo of a {}"
    """Prompt template for the category text. Default: the project's choice."""
    clip_crop_margin: float = 0.1
    """Margin added around the mask's bounding box when cropping, as a fraction of its size.
    Default: the project's choice."""
    appearance_bins: int = 12
    """Appearance scorer: rg-chromaticity bins per axis. Default: the project's choice."""
    appearance_brightness_bins: int = 3
    """Appearance scorer: brightness bins. Default: the project's choice."""
    appearance_floor: float = 1e-3
    """Appearance scorer: likelihood floor added to every reference-histogram bin. Default: the project's choice."""
    appearance_same_similarity: float = 0.9
    """Appearance scorer: instances whose references are at least this similar are not competitors.
    Default: the project's choice."""


class KeyFrameConfig(_Section):
    """Key-frame selection by greedy 3D coverage (paper Appendix 'Key-Frame Selection')."""

    budget: int = 20
    """Frame budget. Default: the paper's (Appendix 'Key-Frame Selection')."""
    voxel_divisor: float = 20.0
    """Voxel size = shortest side of the sampled scene box / this.
    Default: the paper's (Appendix 'Key-Frame Selection')."""
    min_voxel_size: float = 1e-3
    """Lower bound of the voxel size (m). Default: the paper's (Appendix 'Key-Frame Selection')."""
    max_points: int = 250000
    """Most global points sampled. Default: the paper's (Appendix 'Key-Frame Selection')."""
    min_confidence: float = 0.10
    """Least point confidence for sampling. Default: the paper's (Appendix 'Key-Frame Selection')."""
    min_mask_match: float = 0.55
    """A frame is eligible at this mask-match ratio or more. Default: the paper's (Appendix 'Key-Frame Selection')."""
    min_visible_instances: int = 5
    """A frame is eligible with at least this many visible instances.
    Default: the paper's (Appendix 'Key-Frame Selection')."""
    occlusion_aware: bool = True
    """Leave voxels occluded by other surfaces (capture depth) out of the mask-match ratio (not in the paper).
    Default: the project's choice."""
    occlusion_margin: float = 0.05
    """A voxel centre this far (m) behind the observed depth at its pixel counts as occluded.
    Default: the project's choice."""
    include_structural: bool = False
    """Also voxelise floor/wall/ceiling points (the relation graph is over objects, so off by default).
    Default: the project's choice."""
    seed: int = 0
    """Seed of the point subsampling. Default: the project's choice."""
