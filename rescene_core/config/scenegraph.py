"""Sections of relation inference and fusion: the VLM client, the geometric backend, multi-frame fusion."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from rescene_core.config.base import _Section


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
