"""Run configuration: one pydantic model per stage, defaults = the paper's appendix tables where it has them.

``RunConfig`` is the single parameter of the flow. Sections nest (``assets.lift``, ``scenegraph.vlm`` /
``geometric`` / ``fusion``); ``--set section.sub.field=value`` and config.yaml reach every level. Each
field's docstring ends by saying whose default it is: "Default: the paper's (<table or appendix>)" or
"Default: the project's choice" (tests/test_config.py checks every field). Sections are hashed separately
(``section_hash``) so a changed registration parameter invalidates registration and what follows it,
and nothing before it.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)


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


class LiftConfig(_Section):
    """The weight-free ``lift`` asset backend (rescene_core/assets/lift.py): a solid from the chosen view's
    masked depth, its unseen back completed by a mirror image or a slab. Not in the paper: every default
    is the project's choice."""

    resolution: int = 40
    """Grid cells along the object's longest side for the solid fill and marching cubes.
    Default: the project's choice."""
    min_pixels: int = 50
    """Fewest mask pixels with valid depth to build an asset from. Default: the project's choice."""
    mask_erosion: int = 1
    """Mask erosion (pixels) before lifting, to drop mixed depths at the silhouette. Default: the project's choice."""
    mirror: bool = True
    """Complete the unseen back (mirror image of the visible surface, or a slab for flat objects).
    Default: the project's choice."""
    normal_neighbours: int = 40
    """Nearest points per normal estimate (Open3D) for the dominant-face vote. Default: the project's choice."""
    min_incidence_cos: float = 0.5
    """Floor of |cos| between normal and viewing ray in a pixel's surface-area weight. Default: the project's choice."""
    min_axis_strength: float = 0.2
    """Agreement (0-1) of the visible vertical faces on one rectangular orientation below which the
    mirror normal is the horizontal direction towards the camera instead (round objects).
    Default: the project's choice."""
    extent_percentile: float = 1.0
    """Robust extents of the visible points use this percentile and 100 minus it. Default: the project's choice."""
    depth_visible_factor: float = 1.0
    """Completed depth along the mirror normal = this x the visible depth extent (1: the mirror
    plane halves the visible extent; 2: it lies at the farthest visible point). Default: the project's choice."""
    max_depth_ratio: float = 1.0
    """Completed depth at most this x the visible width across the mirror normal (never below the
    visible depth). Default: the project's choice."""
    noise_erosion: int = 3
    """Mask erosion (pixels) of the region whose depth noise is measured (MAD about a 5x5 median).
    Default: the project's choice."""
    flat_inlier_fraction: float = 0.8
    """Fraction of the visible points the flatness plane is fitted to (trimmed PCA). Default: the project's choice."""
    flat_noise_factor: float = 2.0
    """Visible points are flat when 90 % lie within this x the depth noise of one plane...
    Default: the project's choice."""
    flat_min_tolerance: float = 0.02
    """...or within this fraction of the plane's in-plane extent (noise-free depth). Default: the project's choice."""
    flat_max_tilt_deg: float = 30.0
    """A flat object's plane normal must lie within this angle (deg) of horizontal (upright panels).
    Default: the project's choice."""
    slab_fraction: float = 0.04
    """A flat object's slab thickness as a fraction of its outline's longest side. Default: the project's choice."""
    slab_min_m: float = 0.03
    """Smallest slab thickness (m) of a flat object. Default: the project's choice."""
    join_cells: int = 3
    """The solid keeps its largest connected part, parts less than this many grid cells apart
    counting as connected; thin legs, stems and depth dropouts split one object into parts a cell or two
    apart (keeping only the largest left chairs without legs, lamps without a shade), while stray depth
    pixels form islands farther off (0: strict connectivity, the earlier behaviour). Default: the project's choice."""


class AssetConfig(_Section):
    """Single-view asset generation."""

    backend: Literal["lift", "sam3d"] = "lift"
    """'lift' (weight-free CPU) or 'sam3d' (SAM 3D Objects on a GPU worker). Default: the project's choice."""
    sam3d_checkpoint: str | None = None
    """Local path of the SAM 3D Objects checkpoint (sam3d backend only). Default: the project's choice."""
    target_faces: int = 4000
    """Face budget of generated meshes. Default: the project's choice."""
    sam3d_code_dir: str | None = None
    """Local clone of facebookresearch/sam-3d-objects whose notebook/inference.py is loaded by its path (sam3d
    only; unset: the clone of the installed sam3d_objects package).
    Default: the project's choice."""
    seed: int = 42
    """Generator seed (sam3d). Default: the project's choice."""
    lift: LiftConfig = Field(default_factory=LiftConfig)
    """Settings of the ``lift`` backend."""


class RegistrationConfig(_Section):
    """Bounded Sim(3) registration (paper Table 'Default registration hyperparameters')."""

    scale_min: float = 0.90
    """s_min: lower bound of the refinement scale.
    Default: the paper's (Table 'Default registration hyperparameters')."""
    scale_max: float = 1.10
    """s_max: upper bound of the refinement scale.
    Default: the paper's (Table 'Default registration hyperparameters')."""
    scale_regularization: float = 0.30
    """Weight pulling the per-step scale update towards 1.
    Default: the paper's (Table 'Default registration hyperparameters')."""
    max_step_rotation_deg: float = 20.0
    """theta_step: per-iteration rotation clamp (deg).
    Default: the paper's (Table 'Default registration hyperparameters')."""
    max_total_rotation_deg: float = 20.0
    """theta_tot: accumulated refinement rotation clamp from the initialisation (deg).
    Default: the paper's (Table 'Default registration hyperparameters')."""
    init_rotation_gate_deg: float = 50.0
    """Initialisation rotation gate (deg). Default: the paper's (Table 'Default registration hyperparameters')."""
    result_rotation_gate_deg: float = 50.0
    """Result rotation gate (deg). Default: the paper's (Table 'Default registration hyperparameters')."""
    rmse_worsening_tolerance: float = 0.0
    """Allowed RMSE increase of a refinement (m).
    Default: the paper's (Table 'Default registration hyperparameters')."""
    inlier_drop_tolerance: float = 0.01
    """Allowed inlier-ratio drop of a refinement.
    Default: the paper's (Table 'Default registration hyperparameters')."""
    voxel_ratio: float = 0.02
    """Open3D voxel size as a fraction of the target extent.
    Default: the paper's (Table 'Default registration hyperparameters')."""
    max_iterations: int = 60
    """ICP iterations at most. Default: the project's choice."""
    keep_quantile: float = 0.70
    """Correspondences below this distance quantile are kept. Default: the project's choice."""
    max_distance_ratio: float = 0.10
    """Correspondences farther than this fraction of the target extent are rejected. Default: the project's choice."""
    min_correspondences: int = 80
    """Fewest correspondences for an ICP step. Default: the project's choice."""
    source_samples: int = 5000
    """Points sampled on the asset mesh. Default: the project's choice."""
    ransac_iterations: int = 5000
    """RANSAC iterations per restart of the FPFH initialisation (several short restarts beat one long run).
    Default: the project's choice."""
    seed: int = 0
    """Seed of the sampling and RANSAC: source samples and target subsample use it (numpy), RANSAC restart r
    seeds Open3D's process-wide engine with seed + r under a lock (geometry/open3d_rng.py); the seeds
    used are recorded in pose.json (diagnostics 'seeds'). Default: the project's choice."""
    max_target_points: int = 3000
    """Target points kept (seeded random subsample) for registration; bounds the time per instance.
    Default: the project's choice."""
    ransac_restarts: int = 4
    """Independently seeded FPFH+RANSAC runs; each gated candidate is refined, the best by symmetric fitness kept.
    Default: the project's choice."""
    ransac_confidence: float = 0.999
    """RANSAC stops early at this confidence. Default: the project's choice."""
    ransac_distance_voxels: float = 1.5
    """RANSAC inlier distance in voxels of the normalised clouds. Default: the project's choice."""
    ransac_edge_length: float = 0.75
    """Open3D edge-length checker similarity (loose: the partial target's extent differs from the asset's).
    Default: the project's choice."""
    normal_radius_voxels: float = 2.0
    """Normal-estimation radius in voxels (FPFH). Default: the project's choice."""
    feature_radius_voxels: float = 5.0
    """FPFH feature radius in voxels. Default: the project's choice."""
    max_init_scale_ratio: float = 2.0
    """A RANSAC candidate whose scale differs from the extent ratio by more than this factor is rejected.
    Default: the project's choice."""
    icp_tolerance: float = 1e-5
    """ICP stops when a step moves the pose by less than this fraction of the target extent.
    Default: the project's choice."""
    degenerate_ratio: float = 1e-3
    """A cloud whose 2nd or 3rd principal spread is below this fraction of the 1st is planar/collinear.
    Default: the project's choice."""
    cluster_eps_spacings: float = 5.0
    """Target cleaning: DBSCAN radius in median nearest-neighbour spacings; the largest cluster is kept
    (mask bleed puts stray points across the room, which would inflate the extent and so the scale).
    Default: the project's choice."""
    cluster_min_points: int = 5
    """Target cleaning: DBSCAN core-point neighbourhood size. Default: the project's choice."""
    min_result_inlier_ratio: float = 0.5
    """A final pose with fewer target inliers than this becomes Missing instead of a wild pose.
    Default: the project's choice."""
    upright_snap: bool = True
    """A RANSAC candidate rejected only by the (gravity-up tilt) rotation gate is also tried turned upright
    (smallest rotation taking the asset's up axis to world +z, about the asset's centre); the turned pose
    passes every gate itself. Flat and symmetric objects (pictures, clocks, mirrors, boxes) otherwise lose
    their well-fitting candidates to an arbitrary in-plane rotation. No effect with a placement prior.
    Default: the project's choice."""
    ransac_early_exit_inlier_ratio: float = 0.95
    """Early exit of the RANSAC restarts: once an accepted candidate (all gates passed) has this target
    inlier ratio, the remaining restarts are skipped (> 1 disables the exit). Default: the project's choice."""
    probe_iterations: int = 15
    """With several accepted candidates, each is first refined for this many ICP iterations and only the
    best by symmetric fitness gets the full ``max_iterations`` from its own initialisation (0 refines all).
    Default: the project's choice."""
    extent_percentile: float = 2.0
    """Robust extents (%): the normalisation box of the source samples and of the target (its centre and
    diagonal: the FPFH normalisation, the normalisation pose's scale, the extent ratio of the scale gate,
    the unit of the ICP distances) spans the per-axis percentiles q to 100 - q, so the few percent of
    stray points fused into an instance cloud do not stretch it (0: bounding box, the earlier behaviour).
    Default: the project's choice."""


class VlmClientConfig(_Section):
    """The OpenAI-compatible VLM client of the relation predictor (backend 'openai') and the validation of
    its answers (paper Appendix 'Key-Frame Selection and Scene Graph Prompting')."""

    base_url: str | None = None
    """OpenAI-compatible base URL (e.g. http://gpu-box:8000/v1); RESCENE_VLM_BASE_URL when unset.
    Default: the project's choice."""
    model: str = "Qwen/Qwen3-VL-32B-Instruct"
    """Model name sent to the endpoint (paper: Qwen3-VL-32B-Instruct).
    Default: the paper's (Sec. 'Per-frame inference')."""
    api_key_env: str = "RESCENE_VLM_API_KEY"
    """Environment variable holding the API key (the key itself is never stored). Default: the project's choice."""
    api_key: str | None = Field(default=None, repr=False, exclude=True)
    """API key given in code (never written out: excluded from dumps, hashes and repr); else api_key_env.
    Default: the project's choice."""
    timeout_s: float = 120.0
    """Per-request timeout (s). Default: the project's choice."""
    max_concurrency: int = 4
    """Concurrent requests at most. Default: the project's choice."""
    transport_retries: int = 3
    """Retries with backoff on transport errors (timeouts, 5xx). Default: the project's choice."""
    backoff_s: float = 1.0
    """First transport-retry delay (s); doubles on each retry. Default: the project's choice."""
    temperature: float = 0.0
    """Sampling temperature sent to the endpoint. Default: the project's choice."""
    max_tokens: int = 2048
    """Largest answer length requested from the endpoint (tokens). Default: the project's choice."""
    retry_budget: int = 2
    """Validation retries with the errors and the previous JSON in the prompt.
    Default: the paper's (Appendix 'Key-Frame Selection and Scene Graph Prompting')."""
    min_id_coverage: float = 0.95
    """Least fraction of visible ids an answer must cover.
    Default: the paper's (Appendix 'Key-Frame Selection and Scene Graph Prompting')."""


class GeometricConfig(_Section):
    """The weight-free geometric relation predictor (backend 'geometric'); the fusion's support prior
    measures support with the same support settings. Not in the paper: the project's choices."""

    floor_contact_tol: float = 0.05
    """An instance touches the floor when its lowest visible points are this close (m).
    Default: the project's choice."""
    support_tol: float = 0.06
    """Height tolerance of a contact between a child's bottom and a support's upward surface (m): the surface
    may lie this far above the child's bottom (depth noise), and a support that does not reach further down
    than this below the child's bottom must not rise above it beside the child. Default: the project's choice."""
    support_gap: float = 0.06
    """Most free space between a child's bottom and the support surface under it for a rests-on answer (m):
    rests-on is contact, so a child whose bottom is further above an object's top (a wall cabinet 0.6 m above
    a cup) does not rest on it, in the per-frame rules and in fusion's support prior. The paper is silent.
    Default: the project's choice (the contact tolerance support_tol)."""
    support_radius: float = 0.10
    """Horizontal radius within which a support-surface point counts as under a child point (m).
    Default: the project's choice."""
    min_support_overlap: float = 0.25
    """Least fraction of a child's footprint over a parent's surface for an object-support edge.
    Default: the project's choice."""
    wall_tol: float = 0.08
    """Largest distance of a child's back to a wall plane for a mounts-on-wall answer (m).
    Default: the project's choice."""
    wall_max_depth: float = 0.15
    """A thing hung on a wall spans at most this distance off the wall in one view (m).
    Default: the project's choice."""
    wall_flush_tol: float = 0.08
    """A thing whose visible points lie in bulk (median) this close to a wall plane, spanning
    at most wall_max_depth off it, is flat against the wall and hangs on it whatever is beneath (m).
    Default: the project's choice."""
    min_points: int = 20
    """Fewest visible points of an instance to reason about it geometrically. Default: the project's choice."""
    upward_normal_deg: float = 25.0
    """A parent point belongs to an upward face when its normal is within this angle of +z (deg).
    Default: the project's choice."""
    normal_neighbours: int = 16
    """Neighbours used to estimate point normals for the support prior. Default: the project's choice."""


class FusionConfig(_Section):
    """Multi-frame fusion of the per-frame predictions (paper Appendix 'Multi-Frame Fusion Details' and
    'Scene Graph Fusion')."""

    alpha: float = 0.60
    """Vote weight. Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    beta: float = 0.25
    """Geometric-prior weight. Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    gamma: float = 0.15
    """Category-prior weight. Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    shell_weight: float = 0.15
    """Room-shell prior weight; the others are rescaled by 1 - this.
    Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    use_shell_prior: bool = True
    """Add the room-shell prior when a shell is available.
    Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    uncertain_margin: float = 0.15
    """Edges with a top-2 margin below this are uncertain.
    Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    uncertain_top: float = 0.65
    """Edges with a top score below this are uncertain. Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    low_confidence: float = 0.60
    """Low-confidence reporting threshold. Default: the paper's (Appendix 'Multi-Frame Fusion Details')."""
    floor_sigma: float = 0.05
    """Floor-contact prior falls off as exp(-(gap/sigma)^2) with the bottom-to-floor gap (m).
    Default: the project's choice."""
    wall_sigma: float = 0.10
    """Wall-alignment prior falls off as exp(-(residual/sigma)^2) with the back-to-wall residual (m);
    the back itself is hidden, so the residual includes the object's thickness. Default: the project's choice."""
    support_sigma: float = 0.05
    """Object-support prior falls off as exp(-(gap/sigma)^2) with the bottom-to-face gap (m).
    Default: the project's choice."""
    max_fusion_points: int = 20000
    """Most points per instance used by the fusion priors (uniform subsample, seeded). Default: the project's choice."""
    outlier_eps: float = 0.05
    """An instance's points that DBSCAN (Open3D, this radius in m) leaves as noise are dropped before
    the priors measure it: stray points of mask edges and mixed depth lie scattered across the room and
    otherwise set the bottom height and the footprint's orientation. Default: the project's choice."""
    outlier_min_points: int = 8
    """DBSCAN neighbourhood size for ``outlier_eps`` (0 keeps every point). Default: the project's choice."""
    prior_path: str | None = None
    """Category co-occurrence table; None = the shipped rescene_core/data/relation_prior.json.
    Default: the project's choice."""
    ab_frames: int = 3
    """High-visibility frames re-asked with the A/B prompt per uncertain edge (VLM backends).
    Default: the project's choice."""
    ab_geometry_margin: float = 0.20
    """An A/B answer is rejected when its geometric prior is below the other candidate's by more than this.
    Default: the project's choice."""


class SceneGraphConfig(_Section):
    """Per-frame relation inference and multi-frame fusion (paper Appendix 'Multi-Frame Fusion Details')."""

    backend: Literal["geometric", "openai"] = "geometric"
    """Relation predictor: weight-free geometric, or an OpenAI-compatible VLM endpoint.
    Default: the project's choice."""
    min_visible_pixels: int = 100
    """An instance is visible in a frame (shown with an id) from this many mask pixels (a_min of HierView).
    Default: HierView's a_min (Table 'Default HierView hyperparameters'), reused here by the project."""
    overlay_font_px: int = 0
    """Height of the id labels in the overlay images (pixels); 0 = image height / 28, at least 12.
    Default: the project's choice."""
    vlm: VlmClientConfig = Field(default_factory=VlmClientConfig)
    """The VLM client (backend 'openai')."""
    geometric: GeometricConfig = Field(default_factory=GeometricConfig)
    """The geometric predictor (backend 'geometric') and the support geometry the fusion shares."""
    fusion: FusionConfig = Field(default_factory=FusionConfig)
    """Multi-frame fusion."""


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
    bed_labels: tuple[str, ...] = ("bed",)
    """Labels the bed-wall refinement applies to. Default: the project's choice."""
    cabinet_labels: tuple[str, ...] = ("cabinet", "wardrobe", "dresser", "bookshelf", "bookcase", "shelf")
    """Labels the cabinet-corner refinement applies to. Default: the project's choice."""
    stop_after: Literal["relations", "repair", "full"] = "full"
    """Last stage run: relational layer only, + room/wall repair, or full (+ depenetration).
    Default: the project's choice."""


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


class RunConfig(_Section):
    """Everything one run of the flow needs besides the capture and the run directory."""

    shell: ShellConfig = Field(default_factory=ShellConfig)
    hierview: HierViewConfig = Field(default_factory=HierViewConfig)
    keyframes: KeyFrameConfig = Field(default_factory=KeyFrameConfig)
    assets: AssetConfig = Field(default_factory=AssetConfig)
    registration: RegistrationConfig = Field(default_factory=RegistrationConfig)
    scenegraph: SceneGraphConfig = Field(default_factory=SceneGraphConfig)
    attachment: AttachmentConfig = Field(default_factory=AttachmentConfig)
    export: ExportConfig = Field(default_factory=ExportConfig)
    sim: SimcheckConfig = Field(default_factory=SimcheckConfig)
    vqa: VqaConfig = Field(default_factory=VqaConfig)

    def section_hash(self, name: str) -> str:
        """Stable hash of one section's values (for cache keys)."""
        section = getattr(self, name)
        blob = json.dumps(section.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def with_overrides(self, assignments: list[str]) -> RunConfig:
        """Apply ``section.field=value`` or ``section.sub.field=value`` overrides (values parsed as YAML
        scalars), e.g. ``scenegraph.vlm.base_url=http://gpu:8000/v1`` or ``assets.lift.resolution=48``."""
        data = self.model_dump(mode="json")
        for item in assignments:
            key, sep, raw = item.partition("=")
            parts = key.strip().split(".")
            if not sep or len(parts) < 2 or not all(parts):
                raise ValueError(f"--set expects section.field=value (or section.sub.field=value), got {item!r}")
            node = data
            for depth, part in enumerate(parts[:-1]):
                child = node.get(part)
                if not isinstance(child, dict):
                    where = ".".join(parts[:depth]) or "sections"
                    choices = ", ".join(sorted(k for k, v in node.items() if isinstance(v, dict)))
                    raise ValueError(f"--set {key}: {part!r} is not one of the {where} ({choices})")
                node = child
            name = parts[-1]
            if isinstance(node.get(name), dict):
                fields = ", ".join(sorted(node[name]))
                raise ValueError(f"--set {key}: {key} is a group of settings; set one of them ({fields})")
            if name not in node:
                group = ".".join(parts[:-1])
                raise ValueError(f"--set {key}: {group} has no setting {name!r} (settings: {', '.join(sorted(node))})")
            node[name] = yaml.safe_load(raw)
        return RunConfig.model_validate(data)


def load_config(path: str | Path | None = None, overrides: list[str] | None = None) -> RunConfig:
    """Read a YAML config file (missing fields take the defaults) and apply ``--set`` overrides."""
    data: dict[str, Any] = {}
    if path is not None:
        loaded = yaml.safe_load(Path(path).read_text())
        if loaded is not None and not isinstance(loaded, dict):
            raise ValueError(f"{path}: expected a mapping of sections, got {type(loaded).__name__}")
        data = loaded or {}
    config = RunConfig.model_validate(data)
    return config.with_overrides(overrides or [])
