"""Run configuration: one pydantic model per stage, defaults = the paper's appendix tables.

``RunConfig`` is the single parameter of the flow. Each section's fields carry a one-line docstring
naming where the value comes from. Sections are hashed separately (``section_hash``) so a changed
registration parameter invalidates registration and what follows it, and nothing before it.
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
    """RANSAC inlier distance for floor and wall planes (m)."""
    min_wall_points: int = 200
    """Fewest inlier points for a wall plane to be kept."""
    max_walls: int = 12
    """Most wall planes extracted."""
    vertical_tolerance_deg: float = 10.0
    """Largest tilt of a wall normal from horizontal (deg)."""
    sample_voxel: float = 0.02
    """Voxel size the points are thinned to before plane fitting (m)."""
    floor_min_fraction: float = 0.2
    """Without floor labels: the floor is the lowest height bin holding at least this fraction of the densest bin."""
    wall_max_outside_fraction: float = 0.02
    """Without wall labels: a vertical plane is a wall only if at most this fraction of points lies behind it."""
    wall_min_height: float = 1.0
    """Without wall labels: least vertical extent of a wall plane's inliers (m)."""
    merge_angle_deg: float = 10.0
    """Wall planes closer than this angle and merge_distance in offset are merged (deg)."""
    merge_distance: float = 0.2
    """Parallel wall planes closer than this, with overlapping segments, are one wall (noisy depth splits a
    wall into slabs) (m)."""
    wall_refine_band: float = 0.15
    """Half-width of the slab a wall plane is refitted to (median offset, line fit of its footprint) (m)."""
    wall_refine_iterations: int = 3
    """Refits of a wall plane to its slab."""
    polygon_snap_distance: float = 0.3
    """Wall lines this far outside the floor points' outline still bound the floor polygon (m)."""
    polygon_cell_min_coverage: float = 0.5
    """A cell of the wall-line arrangement is floor when the floor outline covers at least this fraction."""
    polygon_sliver: float = 0.05
    """Opening radius of the floor polygon: spikes and slivers narrower than twice this go (m)."""
    polygon_concave_ratio: float = 1.0
    """shapely concave_hull ratio of the floor outline before walls cut it (1 = convex hull; lower follows
    holes that furniture leaves in the floor points)."""
    polygon_simplify: float = 0.01
    """Douglas-Peucker tolerance of the floor polygon (m)."""
    ransac_iterations: int = 1000
    """RANSAC iterations per plane."""
    seed: int = 0
    """Seed of the RANSAC plane fits."""


class HierViewConfig(_Section):
    """HierView view selection (paper Table 'Default HierView hyperparameters')."""

    method: Literal["hierview", "largest_mask", "completeness_only"] = "hierview"
    """Selection method: HierView, or the largest-mask / completeness-only baselines of the paper."""
    min_mask_area: int = 100
    """a_min: minimum mask pixel count for a candidate view (pixels)."""
    min_bbox_ratio: float = 0.01
    """b_min: minimum mask-bounding-box area over image area."""
    semantic_backend: Literal["clip", "appearance", "none"] = "appearance"
    """Semantic scorer: open_clip ViT-B/32, a weight-free appearance-consistency scorer, or none."""
    semantic_fallback: Literal["appearance", "none"] = "appearance"
    """Scorer used when the CLIP weights cannot be found (the log and report say so)."""
    tau_s: float = 0.12
    """tau_s: semantic probability threshold (paper Table A1)."""
    semantic_rank_keep: int = 3
    """Candidates of semantic rank <= this are kept regardless of tau_s."""
    semantic_min_keep: int = 2
    """Keep at least this many candidates after semantic filtering, when available."""
    max_points: int = 30000
    """Most instance points projected for the completeness ranking."""
    clip_model: str = "ViT-B-32"
    """open_clip model name (paper: ViT-B/32)."""
    clip_weights: str | None = None
    """Local path to CLIP weights; RESCENE_CLIP_WEIGHTS is read when unset. Never downloaded."""
    clip_batch_size: int = 64
    """Crops per CLIP forward pass."""
    clip_prompt: str = "a photo of a {}"
    """Prompt template for the category text."""
    clip_crop_margin: float = 0.1
    """Margin added around the mask's bounding box when cropping, as a fraction of its size."""
    appearance_bins: int = 12
    """Appearance scorer: rg-chromaticity bins per axis."""
    appearance_brightness_bins: int = 3
    """Appearance scorer: brightness bins."""
    appearance_floor: float = 1e-3
    """Appearance scorer: likelihood floor added to every reference-histogram bin."""
    appearance_same_similarity: float = 0.9
    """Appearance scorer: instances whose references are at least this similar are not competitors."""


class KeyFrameConfig(_Section):
    """Key-frame selection by greedy 3D coverage (paper Appendix 'Key-Frame Selection')."""

    budget: int = 20
    """Frame budget."""
    voxel_divisor: float = 20.0
    """Voxel size = shortest side of the sampled scene box / this."""
    min_voxel_size: float = 1e-3
    """Lower bound of the voxel size (m)."""
    max_points: int = 250000
    """Most global points sampled."""
    min_confidence: float = 0.10
    """Least point confidence for sampling."""
    min_mask_match: float = 0.55
    """A frame is eligible at this mask-match ratio or more."""
    min_visible_instances: int = 5
    """A frame is eligible with at least this many visible instances."""
    occlusion_aware: bool = True
    """Leave voxels occluded by other surfaces (capture depth) out of the mask-match ratio (not in the paper)."""
    occlusion_margin: float = 0.05
    """A voxel centre this far (m) behind the observed depth at its pixel counts as occluded."""
    include_structural: bool = False
    """Also voxelise floor/wall/ceiling points (the relation graph is over objects, so off by default)."""
    seed: int = 0
    """Seed of the point subsampling."""


class AssetConfig(_Section):
    """Single-view asset generation."""

    backend: Literal["lift", "sam3d"] = "lift"
    """'lift' (weight-free CPU) or 'sam3d' (SAM 3D Objects on a GPU worker)."""
    sam3d_checkpoint: str | None = None
    """Local path of the SAM 3D Objects checkpoint (sam3d backend only)."""
    target_faces: int = 4000
    """Face budget of generated meshes."""
    sam3d_code_dir: str | None = None
    """Local clone of facebookresearch/sam-3d-objects whose notebook/inference.py is imported (sam3d only)."""
    seed: int = 42
    """Generator seed (sam3d)."""
    lift_resolution: int = 40
    """lift: grid cells along the object's longest side for the solid fill and marching cubes."""
    lift_min_pixels: int = 50
    """lift: fewest mask pixels with valid depth to build an asset from."""
    lift_mask_erosion: int = 1
    """lift: mask erosion (pixels) before lifting, to drop mixed depths at the silhouette."""
    lift_mirror: bool = True
    """lift: complete the unseen back (mirror image of the visible surface, or a slab for flat objects)."""
    lift_normal_neighbours: int = 40
    """lift: nearest points per normal estimate (Open3D) for the dominant-face vote."""
    lift_min_incidence_cos: float = 0.5
    """lift: floor of |cos| between normal and viewing ray in a pixel's surface-area weight."""
    lift_min_axis_strength: float = 0.2
    """lift: agreement (0-1) of the visible vertical faces on one rectangular orientation below which the
    mirror normal is the horizontal direction towards the camera instead (round objects)."""
    lift_extent_percentile: float = 1.0
    """lift: robust extents of the visible points use this percentile and 100 minus it."""
    lift_depth_visible_factor: float = 1.0
    """lift: completed depth along the mirror normal = this x the visible depth extent (1: the mirror
    plane halves the visible extent; 2: it lies at the farthest visible point)."""
    lift_max_depth_ratio: float = 1.0
    """lift: completed depth at most this x the visible width across the mirror normal (never below the
    visible depth)."""
    lift_noise_erosion: int = 3
    """lift: mask erosion (pixels) of the region whose depth noise is measured (MAD about a 5x5 median)."""
    lift_flat_inlier_fraction: float = 0.8
    """lift: fraction of the visible points the flatness plane is fitted to (trimmed PCA)."""
    lift_flat_noise_factor: float = 2.0
    """lift: visible points are flat when 90 % lie within this x the depth noise of one plane..."""
    lift_flat_min_tolerance: float = 0.02
    """lift: ...or within this fraction of the plane's in-plane extent (noise-free depth)."""
    lift_flat_max_tilt_deg: float = 30.0
    """lift: a flat object's plane normal must lie within this angle (deg) of horizontal (upright panels)."""
    lift_slab_fraction: float = 0.04
    """lift: a flat object's slab thickness as a fraction of its outline's longest side."""
    lift_slab_min_m: float = 0.03
    """lift: smallest slab thickness (m) of a flat object."""
    lift_join_cells: int = 3
    """lift: the solid keeps its largest connected part, parts less than this many grid cells apart
    counting as connected; thin legs, stems and depth dropouts split one object into parts a cell or two
    apart (keeping only the largest left chairs without legs, lamps without a shade), while stray depth
    pixels form islands farther off (0: strict connectivity, the earlier behaviour)."""


class RegistrationConfig(_Section):
    """Bounded Sim(3) registration (paper Table 'Default registration hyperparameters')."""

    scale_min: float = 0.90
    """s_min: lower bound of the refinement scale."""
    scale_max: float = 1.10
    """s_max: upper bound of the refinement scale."""
    scale_regularization: float = 0.30
    """Weight pulling the per-step scale update towards 1."""
    max_step_rotation_deg: float = 20.0
    """theta_step: per-iteration rotation clamp (deg)."""
    max_total_rotation_deg: float = 20.0
    """theta_tot: accumulated refinement rotation clamp from the initialisation (deg)."""
    init_rotation_gate_deg: float = 50.0
    """Initialisation rotation gate (deg)."""
    result_rotation_gate_deg: float = 50.0
    """Result rotation gate (deg)."""
    rmse_worsening_tolerance: float = 0.0
    """Allowed RMSE increase of a refinement (m)."""
    inlier_drop_tolerance: float = 0.01
    """Allowed inlier-ratio drop of a refinement."""
    voxel_ratio: float = 0.02
    """Open3D voxel size as a fraction of the target extent."""
    max_iterations: int = 60
    """ICP iterations at most."""
    keep_quantile: float = 0.70
    """Correspondences below this distance quantile are kept."""
    max_distance_ratio: float = 0.10
    """Correspondences farther than this fraction of the target extent are rejected."""
    min_correspondences: int = 80
    """Fewest correspondences for an ICP step."""
    source_samples: int = 5000
    """Points sampled on the asset mesh."""
    ransac_iterations: int = 5000
    """RANSAC iterations per restart of the FPFH initialisation (several short restarts beat one long run)."""
    seed: int = 0
    """Seed of the sampling and RANSAC: source samples and target subsample use it (numpy), RANSAC restart r
    seeds Open3D's process-wide engine with seed + r under a lock (geometry/open3d_rng.py); the seeds
    used are recorded in pose.json (diagnostics 'seeds')."""
    max_target_points: int = 3000
    """Target points kept (seeded random subsample) for registration; bounds the time per instance."""
    ransac_restarts: int = 4
    """Independently seeded FPFH+RANSAC runs; each gated candidate is refined, the best by symmetric fitness kept."""
    ransac_confidence: float = 0.999
    """RANSAC stops early at this confidence."""
    ransac_distance_voxels: float = 1.5
    """RANSAC inlier distance in voxels of the normalised clouds."""
    ransac_edge_length: float = 0.75
    """Open3D edge-length checker similarity (loose: the partial target's extent differs from the asset's)."""
    normal_radius_voxels: float = 2.0
    """Normal-estimation radius in voxels (FPFH)."""
    feature_radius_voxels: float = 5.0
    """FPFH feature radius in voxels."""
    max_init_scale_ratio: float = 2.0
    """A RANSAC candidate whose scale differs from the extent ratio by more than this factor is rejected."""
    icp_tolerance: float = 1e-5
    """ICP stops when a step moves the pose by less than this fraction of the target extent."""
    degenerate_ratio: float = 1e-3
    """A cloud whose 2nd or 3rd principal spread is below this fraction of the 1st is planar/collinear."""
    cluster_eps_spacings: float = 5.0
    """Target cleaning: DBSCAN radius in median nearest-neighbour spacings; the largest cluster is kept
    (mask bleed puts stray points across the room, which would inflate the extent and so the scale)."""
    cluster_min_points: int = 5
    """Target cleaning: DBSCAN core-point neighbourhood size."""
    min_result_inlier_ratio: float = 0.5
    """A final pose with fewer target inliers than this becomes Missing instead of a wild pose."""
    upright_snap: bool = True
    """A RANSAC candidate rejected only by the (gravity-up tilt) rotation gate is also tried turned upright
    (smallest rotation taking the asset's up axis to world +z, about the asset's centre); the turned pose
    passes every gate itself. Flat and symmetric objects (pictures, clocks, mirrors, boxes) otherwise lose
    their well-fitting candidates to an arbitrary in-plane rotation. No effect with a placement prior."""
    ransac_early_exit_inlier_ratio: float = 0.95
    """Early exit of the RANSAC restarts: once an accepted candidate (all gates passed) has this target
    inlier ratio, the remaining restarts are skipped (> 1 disables the exit)."""
    probe_iterations: int = 15
    """With several accepted candidates, each is first refined for this many ICP iterations and only the
    best by symmetric fitness gets the full ``max_iterations`` from its own initialisation (0 refines all)."""
    extent_percentile: float = 2.0
    """Robust extents (%): the normalisation box of the source samples and of the target (its centre and
    diagonal: the FPFH normalisation, the normalisation pose's scale, the extent ratio of the scale gate,
    the unit of the ICP distances) spans the per-axis percentiles q to 100 - q, so the few percent of
    stray points fused into an instance cloud do not stretch it (0: bounding box, the earlier behaviour)."""


class SceneGraphConfig(_Section):
    """Per-frame relation inference and multi-frame fusion (paper Appendix 'Multi-Frame Fusion Details')."""

    backend: Literal["geometric", "openai"] = "geometric"
    """Relation predictor: weight-free geometric, or an OpenAI-compatible VLM endpoint."""
    base_url: str | None = None
    """OpenAI-compatible base URL (e.g. http://gpu-box:8000/v1); RESCENE_VLM_BASE_URL when unset."""
    model: str = "Qwen/Qwen3-VL-32B-Instruct"
    """Model name sent to the endpoint (paper: Qwen3-VL-32B-Instruct)."""
    api_key_env: str = "RESCENE_VLM_API_KEY"
    """Environment variable holding the API key (the key itself is never stored)."""
    timeout_s: float = 120.0
    """Per-request timeout (s)."""
    max_concurrency: int = 4
    """Concurrent requests at most."""
    transport_retries: int = 3
    """Retries with backoff on transport errors (timeouts, 5xx)."""
    retry_budget: int = 2
    """Validation retries with the errors and the previous JSON in the prompt."""
    min_id_coverage: float = 0.95
    """Least fraction of visible ids an answer must cover."""
    alpha: float = 0.60
    """Vote weight."""
    beta: float = 0.25
    """Geometric-prior weight."""
    gamma: float = 0.15
    """Category-prior weight."""
    shell_weight: float = 0.15
    """Room-shell prior weight; the others are rescaled by 1 - this."""
    use_shell_prior: bool = True
    """Add the room-shell prior when a shell is available."""
    uncertain_margin: float = 0.15
    """Edges with a top-2 margin below this are uncertain."""
    uncertain_top: float = 0.65
    """Edges with a top score below this are uncertain."""
    low_confidence: float = 0.60
    """Low-confidence reporting threshold."""
    api_key: str | None = Field(default=None, repr=False, exclude=True)
    """API key given in code (never written out: excluded from dumps, hashes and repr); else api_key_env."""
    backoff_s: float = 1.0
    """First transport-retry delay (s); doubles on each retry."""
    temperature: float = 0.0
    """Sampling temperature sent to the endpoint."""
    max_tokens: int = 2048
    """Largest answer length requested from the endpoint (tokens)."""
    min_visible_pixels: int = 100
    """An instance is visible in a frame (shown with an id) from this many mask pixels (a_min of HierView)."""
    overlay_font_px: int = 0
    """Height of the id labels in the overlay images (pixels); 0 = image height / 28, at least 12."""
    floor_contact_tol: float = 0.05
    """Geometric backend: an instance touches the floor when its lowest visible points are this close (m)."""
    support_tol: float = 0.06
    """Geometric backend: largest gap between a child's bottom and a support surface beneath it (m)."""
    support_radius: float = 0.10
    """Horizontal radius within which a support-surface point counts as under a child point (m)."""
    min_support_overlap: float = 0.25
    """Least fraction of a child's footprint over a parent's surface for an object-support edge."""
    wall_tol: float = 0.08
    """Geometric backend: largest distance of a child's back to a wall plane for a mounts-on-wall answer (m)."""
    min_points: int = 20
    """Fewest visible points of an instance to reason about it geometrically."""
    wall_max_depth: float = 0.15
    """Geometric backend: a thing hung on a wall spans at most this distance off the wall in one view (m)."""
    wall_flush_tol: float = 0.08
    """Geometric backend: a thing whose visible points lie in bulk (median) this close to a wall plane, spanning
    at most wall_max_depth off it, is flat against the wall and hangs on it whatever is beneath (m)."""
    floor_sigma: float = 0.05
    """Fusion: floor-contact prior falls off as exp(-(gap/sigma)^2) with the bottom-to-floor gap (m)."""
    wall_sigma: float = 0.10
    """Fusion: wall-alignment prior falls off as exp(-(residual/sigma)^2) with the back-to-wall residual (m);
    the back itself is hidden, so the residual includes the object's thickness."""
    support_sigma: float = 0.05
    """Fusion: object-support prior falls off as exp(-(gap/sigma)^2) with the bottom-to-face gap (m)."""
    upward_normal_deg: float = 25.0
    """A parent point belongs to an upward face when its normal is within this angle of +z (deg)."""
    normal_neighbours: int = 16
    """Neighbours used to estimate point normals for the support prior."""
    max_fusion_points: int = 20000
    """Most points per instance used by the fusion priors (uniform subsample, seeded)."""
    outlier_eps: float = 0.05
    """Fusion: an instance's points that DBSCAN (Open3D, this radius in m) leaves as noise are dropped before
    the priors measure it: stray points of mask edges and mixed depth lie scattered across the room and
    otherwise set the bottom height and the footprint's orientation."""
    outlier_min_points: int = 8
    """Fusion: DBSCAN neighbourhood size for ``outlier_eps`` (0 keeps every point)."""
    prior_path: str | None = None
    """Category co-occurrence table; None = the shipped rescene_core/data/relation_prior.json."""
    ab_frames: int = 3
    """High-visibility frames re-asked with the A/B prompt per uncertain edge (VLM backends)."""
    ab_geometry_margin: float = 0.20
    """An A/B answer is rejected when its geometric prior is below the other candidate's by more than this."""


class AttachmentConfig(_Section):
    """Attachment and layout refinement (paper Table 'Default attachment hyperparameters')."""

    contact_gap: float = 0.01
    """Default contact gap (m)."""
    wall_collision_margin: float = 0.02
    """Wall collision margin (m)."""
    wall_corner_margin: float = 0.05
    """Wall corner margin (m)."""
    max_floor_snap: float = 1.40
    """Maximum floor-snap vertical translation (m)."""
    max_floor_yaw_deg: float = 15.0
    """Maximum floor yaw rotation (deg)."""
    max_wall_yaw_deg: float = 35.0
    """Maximum wall yaw rotation (deg)."""
    near_wall_distance: float = 0.45
    """Near-wall auto-snap distance (m)."""
    auto_wall_snap_translation: float = 1.20
    """Auto wall-snap maximum translation (m)."""
    auto_wall_snap_rotation_deg: float = 25.0
    """Auto wall-snap maximum rotation (deg)."""
    cabinet_corner_translation: float = 0.20
    """Cabinet-corner maximum translation (m)."""
    depenetration_iterations: int = 8
    """Depenetration iterations."""
    depenetration_step: float = 0.04
    """Non-wall depenetration step (m)."""
    wall_tangent_step: float = 0.02
    """Wall-tangent depenetration step (m)."""
    near_wall_snap: bool = True
    """Run the near-wall snap refinement."""
    bed_wall: bool = True
    """Run the bed-wall refinement."""
    cabinet_corner: bool = True
    """Run the cabinet-corner refinement."""
    dual_attachment: bool = True
    """Run the wall-aware and the floor-only branch and keep one per object."""
    wall_confidence_min: float = 0.60
    """Dual attachment: a group with a wall edge below this confidence keeps the floor-only branch (paper's
    low-confidence threshold)."""
    max_level_tilt_deg: float = 45.0
    """Floor, wall and support snaps level the asset axis nearest the floor normal when tilted at most this (deg)."""
    floor_yaw_align: bool = False
    """Floor snap also turns the object onto the nearest room axis when within max_floor_yaw_deg."""
    wall_normal_weight: float = 0.5
    """Wall resolution: metres of coplanarity residual one radian of normal mismatch costs."""
    support_normal_deg: float = 10.0
    """Parent faces whose normal is within this angle of the floor normal are support faces (deg)."""
    support_level_tolerance: float = 0.01
    """Support faces within this height of each other form one support level (m)."""
    max_support_snap: float = 1.40
    """Largest vertical move of an object-support snap (m; the floor-snap limit)."""
    support_inner_tolerance: float | None = 0.15
    """Generated parents: a child whose registered bottom lies more than this (m) below the parent's top
    level stands inside the parent, on an inner face (a shelf board) the generated mesh lacks unless it has a
    level within this distance of the child's bottom; without one the support rule is skipped and the child
    stays at its registered height (not lifted onto the top). Shelf boards are 0.25-0.4 m apart, registration
    sinks a child by at most a few centimetres. None: the nearest level of the mesh, or its top, as for exact
    parents (the support contact then passes, on a face 1-2 m from where the child was seen)."""
    near_wall_min_footprint: float = 0.25
    """Near-wall snap only moves floor objects with at least this footprint area (m^2, 'large furniture')."""
    containment_tolerance: float = 0.01
    """A footprint this far (m) beyond the floor polygon still counts as inside."""
    completion_min_excess: float | None = None
    """Generated assets: a crossing of a wall or of the floor polygon deeper than this (m), with the object's
    centre inside, is read as a completion error and left alone; a shallower one is a pose or size error
    and is repaired like an exact shape's. None (default): every crossing is repaired, so nothing is left
    through a wall (a simulator cannot load a bed through a wall); set it (0.20 was the earlier default)
    for a generator whose completions are much deeper than its objects."""
    contact_closure_min_confidence: float = 0.60
    """Edges at least this confident get their contact (floor, support face, wall plane) closed in full
    after the confidence-scaled update; below it the contact is scaled by omega like the rest (the paper's
    low-confidence threshold)."""
    bed_labels: tuple[str, ...] = ("bed",)
    """Labels the bed-wall refinement applies to."""
    cabinet_labels: tuple[str, ...] = ("cabinet", "wardrobe", "dresser", "bookshelf", "bookcase", "shelf")
    """Labels the cabinet-corner refinement applies to."""
    stop_after: Literal["relations", "repair", "full"] = "full"
    """Last stage run: relational layer only, + room/wall repair, or full (+ depenetration)."""


class RunConfig(_Section):
    """Everything one run of the flow needs besides the capture and the run directory."""

    shell: ShellConfig = Field(default_factory=ShellConfig)
    hierview: HierViewConfig = Field(default_factory=HierViewConfig)
    keyframes: KeyFrameConfig = Field(default_factory=KeyFrameConfig)
    assets: AssetConfig = Field(default_factory=AssetConfig)
    registration: RegistrationConfig = Field(default_factory=RegistrationConfig)
    scenegraph: SceneGraphConfig = Field(default_factory=SceneGraphConfig)
    attachment: AttachmentConfig = Field(default_factory=AttachmentConfig)

    def section_hash(self, name: str) -> str:
        """Stable hash of one section's values (for cache keys)."""
        section = getattr(self, name)
        blob = json.dumps(section.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def with_overrides(self, assignments: list[str]) -> RunConfig:
        """Apply ``section.field=value`` overrides (values parsed as YAML scalars)."""
        data = self.model_dump(mode="json")
        for item in assignments:
            key, sep, raw = item.partition("=")
            parts = key.strip().split(".")
            if not sep or len(parts) != 2:
                raise ValueError(f"--set expects section.field=value, got {item!r}")
            section, name = parts
            if section not in data or name not in data[section]:
                raise ValueError(f"--set {key}: unknown setting (sections: {', '.join(sorted(data))})")
            data[section][name] = yaml.safe_load(raw)
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
