"""Sections of the per-object stages: asset generation (the lift backend) and bounded Sim(3) registration."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from rescene_core.config.base import _Section


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
