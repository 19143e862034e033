"""The label-free front end: instance masks for RGB-D scans that have none.

1. TSDF fusion of every frame (Open3D's tensor ``VoxelBlockGrid``, depth and colour thinned by
   ``tsdf_stride`` first) and its surface mesh with vertex colours.
2. Room structure: the floor (z near 0 in the aligned frame), a ceiling (a large horizontal plane above the
   cameras or, seen too little for a plane, the densest slab of downward-facing surface above them) and
   walls (large vertical planes with almost nothing behind them, their ends trimmed where the room lies
   behind the plane: the inner walls of an L-shaped room). A vertex joins a plane only if it lies
   on it and its normal agrees, so the side of a cabinet against a wall stays with the cabinet.
3. Superpoints (``rescene_core.segment.superpoints``): the vertices off the floor and ceiling, thinned to
   ``superpoint_voxel``, are over-segmented by Felzenszwalb-Huttenlocher on normals and colour, as
   ScanNet's mesh segmentation does.
4. Region merging (``merge_superpoints``): touching superpoints join unless their contact is a concave
   crease (a lamp standing on a nightstand, a chair seat meeting a table's edge), a strong change of
   colour, or a support contact (a body standing on a horizontal top and narrower than it: what spans the
   top is its own back or headboard). Small pieces and thin upright ones (legs) join what they touch most;
   slender uprights standing under a broader region (fused table legs, a desk's side panels) join it, and
   so do regions standing against a wall under it (a desk's back legs and rail, fused with the wall) or
   rising against the wall over a region they touch (a bed's headboard);
   regions parted by creases alone join again when one lies within the other's bounds (shelves in a
   bookcase), unless it rests on a top of the other (a book stack on a shelf, a lamp on a nightstand).
   A region ending just under another, its slender upper end under the other's footprint, joins it (a
   table lamp's base and stem under its shade, parted from it by colour and the crease at the rim, or by
   a gap where the fusion lost the stem's thin top), and so does a broad one the other overhangs all round
   (a plant's pot under its foliage, its leaves hanging below the pot's rim beside it).
   A compact body standing on a horizontal top of its own region, the top reaching beyond its foot on three
   sides, is split off at the top's plane (a monitor whose base plate rises a few centimetres), and so is
   a body stored on a shelf of a case, parted from the case's back and sides at its creases and where the
   colour leaves the case's own, with a board of the case over it (a book stack against a bookcase's back
   panel). A small region resting on something that narrows sharply at some height is two bodies, split
   there (a book stack on a stack).
   A region standing upright in a larger one's bounds under a board of it, not in layers, joins it (a row
   of books standing in a bookcase), and a body split off a top joins a shade over it as a stem does (a
   lamp's base, given first to the nightstand it touches most).
   A low flat region lying on a mattress (a large top at a bed's height) joins it: a bed's pillows.
   Wall superpoints stay wall unless their colour differs from the wall's (not as a shadow's does: it
   keeps the wall's hue) or they stand proud of it, and hanging superpoints just off a wall's plane (a
   clock's rim and face) count with them; such a region hanging clear of the floor and ceiling with a
   sharp outline (not a shadow's) or a depth step is a flush object (a picture, a mirror, a clock, a TV),
   its pieces parted by colour joined when one lies within the other (a canvas in its frame). Regions
   too small, too large, upright sheets as tall as a wall and slivers of the structure are dropped; a
   region that would be dropped as a stretch of wall first gives back what stands well out of the wall's
   plane (a desk and its monitor joined to a stretch of wall the plane did not claim), and a region
   reaching well out of its wall gives up the points of the wall's paint or its shadow that superpoints
   holding both took into it (the wall under a wall shelf, fused with its brackets).
5. The labelled mesh is rendered into each camera with a depth test (``rescene_core.segment.project``).

``--segment masks`` (``rescene_core.segment.masks``) replaces step 4 by view consensus of per-frame 2D
masks. Every segment is labelled ``object`` unless an open_clip checkpoint is given: then the best views of
each segment are classified zero-shot over a vocabulary (``rescene_core.segment.labels``). The result says
which segmenter ran (``geometric``, ``masks``, with ``+clip`` when labelled).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from shapely.geometry import MultiPoint, Polygon

from rescene_core.geometry.open3d_rng import seeded_open3d_rng
from rescene_core.render.raycast import RayCaster
from rescene_core.segment.errors import SegmentError
from rescene_core.segment.labels import zero_shot_labels
from rescene_core.segment.project import labelled_meshes, render_masks
from rescene_core.segment.superpoints import SuperpointGraph, edge_weights, felzenszwalb, point_graph, superpoint_graph


class SegmentConfig(BaseModel):
    """Label-free segmentation. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    tsdf_voxel: float = 0.02
    """TSDF voxel size (m)."""
    tsdf_stride: int = 2
    """Every n-th pixel of depth and colour is fused (a 2 cm voxel is larger than a pixel's footprint at 2 m
    on a 640-pixel-wide frame)..."""
    tsdf_min_width: int = 320
    """... as long as at least this many pixels of a row remain (small frames are fused whole)."""
    sdf_trunc_voxels: float = 4.0
    """TSDF truncation distance in voxels."""
    tsdf_block_count: int = 20000
    """Voxel blocks (8^3 voxels each) the TSDF hash map starts with (it grows when needed)."""
    tsdf_min_weight: float = 1.0
    """Least integration weight (frames) of a TSDF voxel on the extracted surface."""
    depth_trunc: float = 5.0
    """Depth beyond this is not fused (m)."""
    floor_band: float = 0.04
    """Vertices below this height (aligned frame, floor at z = 0) are floor (m)."""
    plane_distance: float = 0.03
    """Distance of a vertex to a wall or ceiling plane to belong to it (m)."""
    plane_normal_deg: float = 30.0
    """Largest angle between a vertex normal and a plane normal for the vertex to join the plane (deg)."""
    plane_iterations: int = 1000
    """RANSAC iterations per plane."""
    max_planes: int = 14
    """Most planes peeled off while looking for walls and the ceiling."""
    vertical_tolerance_deg: float = 10.0
    """Largest tilt of a wall normal from horizontal, and of a ceiling normal from vertical (deg)."""
    wall_min_extent: float = 1.0
    """Least width and height of a wall's inliers (m)."""
    wall_shadow: float = 0.4
    """A vertical plane parallel to a wall and less than this in front of it is not a wall (m)."""
    wall_bin: float = 0.1
    """Bin along a wall plane in which its inliers are counted to find the wall's own stretch (m)."""
    wall_max_behind: float = 0.05
    """Largest share of the scene's points behind a wall plane (seen from the cameras)."""
    ceiling_min_above_cameras: float = 0.1
    """A ceiling lies at least this far above the highest camera (m)."""
    ceiling_min_vertices: int = 50
    """A ceiling seen too little for the plane search (only in a corner or along the top of a wall: fewer than
    200 points of ``plane_voxel``) is the densest slab ``2 * plane_distance`` thick of downward-facing mesh
    vertices above the cameras when it holds at least this many (50 vertices of a 2 cm TSDF: 0.02 m^2) and
    fewer than this many vertices lie above it (the ceiling is the top of the room; a pendant lamp's
    underside has its shade above it)."""
    plane_voxel: float = 0.05
    """Voxel size the points are thinned to for the wall and ceiling search (m)."""
    superpoint_voxel: float = 0.025
    """Voxel size of the points that are over-segmented into superpoints (m)."""
    graph_radius_voxels: float = 1.75
    """Points closer than this many ``superpoint_voxel`` share a graph edge."""
    fh_k: float = 0.5
    """Felzenszwalb-Huttenlocher scale: larger gives larger superpoints."""
    masks_fh_k: float = 0.25
    """The scale for ``--segment masks``: finer superpoints, since the masks, not geometry, join them."""
    fh_colour_weight: float = 1.0
    """Weight of the RGB step (0-1) against the normal bend (1 - cos) in an edge's weight."""
    fh_min_size: int = 20
    """Superpoints with fewer points join their cheapest neighbour."""
    min_contacts: int = 3
    """Touching superpoints with fewer graph edges between them are not joined (a bridge of noise)."""
    concave_fraction: float = 0.65
    """Share of concave edges that makes a contact a crease..."""
    concave_colour_step: float = 0.0
    """... that separates two superpoints when their mean colours also differ by at least this (RGB distance /
    sqrt 3; 0: every crease separates, since touching objects of one colour are common)."""
    colour_cut: float = 0.26
    """Touching superpoints whose mean colours differ by this much are never joined (RGB distance / sqrt 3;
    the shading and exposure of a real recording step 0.22 across one surface)."""
    flush_colour_step: float = 0.12
    """A superpoint on a wall whose mean colour differs from the wall's by this much is a flush candidate..."""
    flush_shadow_tint: float = 0.02
    """... unless it is the wall's colour darkened: the rest of its colour after the best darker multiple of
    the wall's is taken off is under this (RGB distance / sqrt 3; a shadow under a shelf keeps the wall's
    hue, 0.001-0.007 off it, a door's or a bookcase back's wood is 0.06 off)..."""
    flush_offset: float = 0.012
    """... as is one standing this far proud of the wall plane on average (m); a region of candidates that
    stands this far proud (median) is a flush object (a TV, a mirror in its frame)..."""
    flush_edge_step: float = 0.2
    """... and, over a whole region on a wall, the mean colour step across its outline against the wall
    (RGB distance / sqrt 3) that makes it a picture or a poster, unless it stands ``flush_offset`` proud."""
    flush_min_height: float = 0.3
    """A flush object hangs at least this far above the floor (a door does not) (m)..."""
    flush_ceiling_gap: float = 0.1
    """... and at least this far below the ceiling (a wall clock hangs higher than a picture; the rounded
    corner where a wall meets the ceiling does not) (m)."""
    flush_max_extent: float = 2.5
    """A flush object is smaller than this in its largest dimension (m); larger ones are the wall."""
    enclosed_fraction: float = 0.9
    """Regions parted by creases alone join again when this share of the smaller lies within the larger's bounds."""
    leg_width: float = 0.12
    """An upright part narrower than this (m) is a leg or a post of what it touches."""
    leg_max_width: float = 0.16
    """An upright region narrower than this one way (m), standing near the floor with its upper end just under
    a broader region, is a leg or a side panel of it (fused legs are fatter than ``leg_width``)."""
    back_depth: float = 0.1
    """A region standing near the floor and lying wholly within this distance (m) in front of one wall, ..."""
    back_reach: float = 0.3
    """... with a broader region's surface up to this far (m) over its upper end, is that one's back legs or
    rail, fused with the wall (the fusion may give a leg's upper part to the wall it stands against)."""
    min_segment_points: int = 80
    """Fewest thinned points of an object segment (80 points of 2.5 cm: 0.05 m^2 of surface); smaller
    regions join their most touching neighbour."""
    masks_min_segment_points: int = 60
    """The least for ``--segment masks``, whose regions are a consensus of views, not fragments of geometry."""
    min_segment_extent: float = 0.1
    """Smallest largest-dimension of an object segment (m)."""
    max_segment_extent: float = 4.0
    """Largest largest-dimension of an object segment; bigger regions are leftovers of the room (m)."""
    depth_abs_tolerance: float = 0.05
    """Mask depth test: absolute tolerance between rendered and measured depth (m)."""
    depth_rel_tolerance: float = 0.05
    """Mask depth test: tolerance as a fraction of the measured depth."""
    min_mask_pixels: int = 30
    """Per frame, a segment's mask with fewer pixels is cleared."""
    support_min_height: float = 0.25
    """A horizontal top higher than this can carry objects that are split off it (m)."""
    support_up_share: float = 0.7
    """Share of a superpoint's normals within 15 degrees of up that makes it a horizontal top."""
    support_span_fraction: float = 0.85
    """A body on a top that spans this fraction of the top's width or depth is the piece's own back
    (a chair's or sofa's back, a headboard) and stays with it."""
    support_band: float = 0.04
    """A body whose lowest point is within this of a top's height, or above it, stands on it (m)."""
    body_min_thickness: float = 0.05
    """A region this thick every way or more can be a body resting on a top; a thinner one is a board or panel
    of the piece (a shelf board's top face and front edge fuse 2-4 cm thick; a stack of two books is 5 cm) (m)."""
    top_min_points: int = 25
    """Fewest upward-facing points in a 3 cm slab that make a horizontal top a body can stand on (0.016 m^2:
    a shelf seen between the things standing on it shows little more)."""
    top_clearance: float = 0.015
    """A body on a top is split off at this height above the top's plane (m): the fused top is about one
    voxel thick."""
    stored_min_height: float = 0.05
    """A shelf of a case at least this high, with a board of the case over what stands on it, can carry a
    body of its own (a bookcase's lowest shelf is 5-10 cm above the floor; without a board over it, a top
    lower than ``support_min_height`` carries none) (m)."""
    foot_height: float = 0.08
    """The foot of a body standing on a top: its points within this height (m) of its lowest point (a
    lamp's base, not the shade overhanging it)."""
    top_margin: float = 0.05
    """A top reaches beyond a body's foot on a side when it extends this far past it there (m)..."""
    top_sides: int = 3
    """... on at least this many of the four sides: a monitor, a lamp or a book stack on a desk (one side may
    be the wall or the desk's edge); a back or an armrest along the seat's edge is the piece's own."""
    stem_margin: float = 0.02
    """A region below another, ending where the other begins (or up to ``stem_gap`` under it), its upper end
    under the other's footprint within this margin (m), ..."""
    stem_gap: float = 0.08
    """... the most (m) a stem's top may end under its shade: the fusion loses a thin stem's top, 1-2 cm
    across, where it enters the shade ..."""
    stem_overlap: float = 0.5
    """... with at least this fraction of its footprint under the other's (a lamp's base may reach past its
    shade) ..."""
    stem_width_fraction: float = 0.5
    """... whose upper end is narrower than this fraction of the other both ways is its stem (a table lamp's
    base and stem under its shade) and joins it."""
    bedding_min_height: float = 0.35
    """A mattress's top is at least this high above the floor (m): a low platform bed's is at 0.35-0.45 m..."""
    bedding_max_height: float = 0.68
    """... and at most this high (m): a tall bed's is at 0.6-0.65 m; a desk's or a dining table's top is at
    0.72-0.78 m."""
    bedding_min_length: float = 1.8
    """A mattress's top is at least this long (m): the shortest mattress, a single's, is 1.9 m, less what
    the fusion may lose at its foot; a coffee table or a sideboard is shorter..."""
    bedding_min_width: float = 0.85
    """... and at least this wide (m): the narrowest, a European single's, is 0.9 m; a sofa's seat is
    0.55-0.75 m deep."""
    bedding_duvet: float = 0.08
    """A mattress's level reaches this far above the lowest point of what lies on it (m): a duvet over part of
    the mattress is 3-8 cm thick, and a pillow may lie on the mattress beside it."""
    bedding_flatness: float = 0.5
    """A region lying on a mattress no taller than this fraction of its smaller horizontal extent is bedding
    and joins the bed (a pillow is 10-20 cm thick on 40-50 cm); a lamp or a person sitting is taller."""
    beside_min_height: float = 0.68
    """A top at least this high (m) (a table's or a desk's is at 0.72-0.78, a tall bed's mattress at most at
    0.65) ..."""
    beside_min_width: float = 0.4
    """... at least this wide both ways (m) (a sofa's back is narrower), whose footprint is as large as a
    square of this side, parts from its region what stands on the floor beside it: chairs at a dining
    table, joined to it where their backs come within a few centimetres of the table's edge. What lies
    within this margin (m) of the footprint's outline stays with the top ..."""
    beside_margin: float = 0.05
    """... (the top's edge face lies up to a voxel beyond its upward-facing points, and the fused surface
    runs on along the edge between two chairs) ..."""
    beside_floor_gap: float = 0.15
    """... and a part beside it is a piece of its own when its lowest point is at most this high (m), ..."""
    beside_rise: float = 0.03
    """... it rises at least this far over the top (m) (a chair's back rises 5-20 cm over a table's top; the
    sides of a case under a top seen only in part end at the top) ..."""
    beside_rise_points: int = 10
    """... with at least this many points (a chair's back rail is 35-45 cm wide: 14-18 points a row; a
    case's side may poke a voxel over its top at a corner), ..."""
    beside_min_tall: float = 0.3
    """... it is at least this tall (m), ..."""
    beside_piece_width: float = 0.25
    """... at least this wide both ways (m) (a chair or a stool is 0.3-0.5 m; a strip of wall in a corner
    beside a cabinet, 10 by 13 cm, is none) and holds fewer than ``top_min_points`` of the top's own
    upward-facing points (a cabinet's end whose top a book stack hides is the cabinet's)."""
    stored_top_sides: int = 1
    """A body stored on a shelf under a board of its case needs its shelf seen beyond it on this many of its
    four sides (the shelf beyond a stack is hidden behind it, or the stack stands against the case's side)."""
    stored_board_reach: float = 0.5
    """A body is stored on a shelf of its case when a board of the case lies at most this far over it (m) (a
    bookcase's shelves are 30-48 cm apart) ..."""
    stored_board_share: float = 0.2
    """... over at least this share of its footprint in 5 cm cells (a board over a stack above the cameras'
    height, seen only along its front edge, covered 37 % of the stack; a picture hung over a bed's
    headboard and pillows, 1 %)."""
    frame_column_bin: float = 0.05
    """A column over a case's shelf, one ``superpoint_voxel`` square, with points in every bin of this height
    (m)..."""
    frame_column_rise: float = 0.3
    """... from the shelf to this far over it (m) is a side or back panel, which bodies stored on the shelf
    are parted from (a stack of two to five books rises under 0.25 m and leaves a gap under the board over
    it; a body filling a column this tall loses that column to the frame)..."""
    frame_column_least: int = 3
    """... or whose bins are filled from its lowest point up to that height without a break, over this many
    bins (a panel seen only above a stack standing in front of it)."""
    case_tint: float = 0.045
    """A point of a case is of the case's own colour when, after the best multiple of its shelf's colour is
    taken off, less than this is left (RGB distance / sqrt 3; the wood or paint lit or shaded: median 0.003-
    0.004 on cluttered 204, 205 and 213; a book stack's points: median 0.05-0.11, 8-39 % under this). Bodies
    stored on the shelf are parted from the case where the colour changes (a stack flush with a panel
    whose corner the fused surface rounds)."""
    row_min_height: float = 0.15
    """A body parted from its case by its colour alone (``case_tint``) whose colour seams run in rows
    (``_in_rows``) is a row of the case's upright books when it is at least this tall (m) (books stand
    16-30 cm tall; a stack of two or three books, 4-10 cm, shows the ledges of its books from above as
    seams running across)."""
    layer_colour_step: float = 0.1
    """A body taken as upright (``stored_cover_gap``) whose point edges stepping this much in colour
    (RGB distance / sqrt 3: the seams between books) ..."""
    layer_share: float = 0.4
    """... run more up than across, this share of them or more, lies in layers (books lying flat, a stack on
    a stack: 0.53-0.59 on cluttered 206-207; rows of upright books 0.07-0.22) and is stored after all..."""
    layer_min_edges: int = 20
    """... when there are this many such edges."""
    stored_cover_gap: float = 0.3
    """A body resting on a shelf inside a larger region, taller than deep, with a board of the larger one at
    most this far over it is stored in it (a row of upright books in a bookcase) and joins it (m)."""
    bracket_min_depth: float = 0.1
    """A slender region hanging under a broader one joins it as its bracket when it reaches at least this far
    out from its wall (m) (a wall shelf's bracket: 16-22 cm; a picture or a mirror lies flat on the wall)."""
    stacked_min_height: float = 0.15
    """A region whose lowest point is at least this high (m), resting on something (a potted plant's
    foliage on the floor narrows upward too), ..."""
    stacked_max_width: float = 0.45
    """... at most this wide either way (m) (a book stack is 15-28 cm; with the edge of the shelf or table it
    rests on, up to 40 cm) and at least ``min_segment_extent`` both ways ..."""
    stacked_min_part: float = 0.03
    """... is two bodies, one resting on the other (a book stack on a book stack), when it can be cut at a
    height at least this far (m) over its foot and under its top (two books of 1.8 cm) ..."""
    stacked_narrowing: float = 0.86
    """... where what is above the cut is at most this share of what is below it, both ways, over the whole
    parts and over the ``stacked_slice`` on either side of the cut (a stack on a stack, at its seam: 0.7-0.98,
    most 0.81-0.85 on cluttered 204-215; the books of one stack, 0.8-1.0 wide each, nowhere under 0.89 on
    the 30 stacks of those seeds segmented alone; a lamp's shade narrowing up: 0.9 or more) ..."""
    stacked_slice: float = 0.03
    """... (m) ..."""
    stacked_max_flare: float = 1.5
    """... and the body below does not flare out upward: its slice under the cut is at most this many times
    as wide as its slice at the foot (the lower stack of a pair: 0.74-1.36 at the 33 cuts on cluttered 0-1
    and 205-215; a plant cut at the crown of its foliage, on standard 212 and cluttered 208: 1.68-1.74,
    the pot at its foot) ..."""
    stacked_min_points: int = 40
    """... with at least this many points above and below the cut (fewer above are a lid or a cap of the body
    below: a jar's lid on the egocentric preset, 27 points), ``stacked_slice_points`` in each slice, and
    ``min_segment_points`` below it."""
    stacked_slice_points: int = 8
    """Fewest points of a slice beside the cut of a stack (see ``stacked_min_points``)."""
    structure_band: float = 0.06
    """A cluster lying within this distance of a wall or ceiling plane is a sliver of it (m)..."""
    sliver_thickness: float = 0.07
    """... when its points also lie within this of the plane (95th percentile), unlike a monitor's (m); the
    fused surface of a wall seen at a grazing angle wanders 5-7 cm about its plane."""
    wall_piece_height: float = 1.8
    """An upright sheet at least this tall is wall (a stretch the plane search missed, a door), not an object (m)."""
    structure_sliver_fraction: float = 0.8
    """Share of a cluster's points within ``structure_band`` of a plane that makes it a sliver."""
    stands_out: float = 0.1
    """A part at least this far off the structure planes stands out of them (m), past the 5-7 cm the fused
    surface of a wall wanders: what stands against a stretch of wall the plane did not claim
    (``part_from_wall_stretch``), and a region reaching this far out of its wall is no flush object
    (``take_off_wall_paint``)."""
    seed: int = 0
    """Seed of Open3D's RANSAC and of the choice of voting points."""
    vote_points: int = 40
    """``--segment masks``: points of each superpoint projected into the frames (at most)."""
    vote_min_points: int = 3
    """... fewest of them visible in a frame for the superpoint to vote there."""
    vote_min_share: float = 0.5
    """... share of its visible points that must read one id for the vote to count."""
    consensus_min_frames: int = 2
    """... fewest frames in which two touching superpoints both vote before they can join..."""
    consensus_fraction: float = 0.6
    """... and the share of those frames that must give both the same id."""
    consensus_gap: float = 0.25
    """... regions whose points come this close (m) without touching through masked superpoints (a lamp's
    shade and base, its 1-2 cm pole left unmasked by eroded mask outlines) can still join by consensus..."""
    gap_min_frames: int = 5
    """... when both cast a confident vote in at least this many frames..."""
    gap_consensus_fraction: float = 0.8
    """... and this share of those frames give both the same id (two separate objects share an id only
    where a 2D segmenter merges them in an image)."""
    unmasked_share: float = 0.5
    """... a superpoint whose vote is no mask (id 0) in this share of the frames it votes in belongs to no
    instance."""
    clip_views: int = 3
    """Views per segment shown to the zero-shot classifier (the largest masks)."""


@dataclass
class SegmentResult:
    """Masks int32 [T, H, W] (0 = none), labels {id: (label, structural)}, the segmenter's name and a report."""

    masks: NDArray[np.int32]
    labels: dict[int, tuple[str, bool]]
    segmenter: str
    report: dict[str, Any] = field(default_factory=dict)
    mesh_vertices: NDArray[np.float64] | None = None
    mesh_faces: NDArray[np.int64] | None = None
    face_labels: NDArray[np.int64] | None = None


def tsdf_mesh(
    rgb: NDArray[np.uint8], depth: NDArray[np.float32], K: NDArray, world_from_cam: NDArray, cfg: SegmentConfig
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """TSDF-fused surface: vertices [v, 3], faces [f, 3], vertex normals [v, 3] (world frame), vertex
    colours [v, 3] in [0, 1]."""
    import open3d as o3d

    core = o3d.core
    # the tensor VoxelBlockGrid (the legacy ScalableTSDFVolume of the open3d 0.20 wheel integrates nothing)
    vbg = o3d.t.geometry.VoxelBlockGrid(
        attr_names=("tsdf", "weight", "color"),
        attr_dtypes=(core.float32, core.float32, core.float32),
        attr_channels=((1), (1), (3)),
        voxel_size=cfg.tsdf_voxel,
        block_resolution=8,
        block_count=cfg.tsdf_block_count,
        device=core.Device("CPU:0"),
    )
    step = max(min(int(cfg.tsdf_stride), depth.shape[2] // max(cfg.tsdf_min_width, 1)), 1)
    for t in range(len(depth)):
        k = np.asarray(K[t], np.float64).copy()
        # Open3D puts pixel centres at integers; the project casts pixel u through u + 0.5. Pixel i of the
        # strided image is pixel step * i of the full one, whose centre is at step * i + 0.5.
        k[0, 2] = (k[0, 2] - 0.5) / step
        k[1, 2] = (k[1, 2] - 0.5) / step
        k[:2, :2] /= step
        intr = core.Tensor(k, core.float64)
        cam_from_world = core.Tensor(np.linalg.inv(np.asarray(world_from_cam[t], np.float64)), core.float64)
        d = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(depth[t][::step, ::step], np.float32)))
        c = o3d.t.geometry.Image(core.Tensor(np.ascontiguousarray(rgb[t][::step, ::step], np.float32) / 255.0))
        blocks = vbg.compute_unique_block_coordinates(
            d, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels
        )
        vbg.integrate(blocks, d, c, intr, intr, cam_from_world, 1.0, cfg.depth_trunc, cfg.sdf_trunc_voxels)
    mesh = vbg.extract_triangle_mesh(weight_threshold=cfg.tsdf_min_weight).to_legacy()
    mesh.compute_vertex_normals()
    colors = np.asarray(mesh.vertex_colors) if mesh.has_vertex_colors() else np.zeros((len(mesh.vertices), 3))
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles, np.int64), np.asarray(mesh.vertex_normals), colors


def _wall_span(along: NDArray, bin_size: float) -> tuple[float, float]:
    """The wall's own stretch along its plane (m): the run of ``bin_size`` bins holding the most of a plane's
    inliers ``along`` [k] (positions along the wall; a bin is occupied with 5 % of the fullest bin's
    count), with gaps up to 0.8 m bridged (a wardrobe hides the wall behind it). Furniture faces that happen
    to be coplanar with the wall elsewhere in the room fall outside."""
    if len(along) == 0:
        return 0.0, 0.0
    edges = np.arange(along.min(), along.max() + 2 * bin_size, bin_size)
    hist, edges = np.histogram(along, bins=edges)
    occupied = hist >= 0.05 * hist.max()
    best, best_pts, start, gap = (0, 0), -1, None, 0
    max_gap = int(round(0.8 / bin_size))
    for i, occ in enumerate(np.r_[occupied, np.zeros(max_gap + 1, bool)]):
        if occ:
            start = i if start is None else start
            gap = 0
            end = i
        elif start is not None:
            gap += 1
            if gap > max_gap:
                pts = int(hist[start : end + 1].sum())
                if pts > best_pts:
                    best, best_pts = (start, end), pts
                start, gap = None, 0
    return float(edges[best[0]]), float(edges[best[1] + 1])


def _trim_overhang(along: NDArray, side: NDArray, lo: float, hi: float, cfg: SegmentConfig) -> tuple[float, float]:
    """A wall's stretch [lo, hi] (m along it) less the ``wall_bin`` bins at either end in which more than
    ``wall_max_behind`` of the scene's points (at positions ``along`` [k], signed distances ``side`` [k] from
    the plane, positive towards the room) lie behind the plane: the inner walls of an L-shaped room, whose
    plane runs on past the corner across the other arm (coplanar faces of furniture there stretch the span
    over it). Nothing is left of a face with the room behind it all along, or behind some bin between the
    ends kept (a wardrobe's front standing in the room before the inner wall it hides)."""
    edges = np.arange(lo, hi + cfg.wall_bin, cfg.wall_bin)
    if len(edges) < 2:
        return lo, hi
    total, _ = np.histogram(along, bins=edges)
    behind, _ = np.histogram(along[side < -2 * cfg.plane_distance], bins=edges)
    ok = behind <= cfg.wall_max_behind * np.maximum(total, 1)
    clear = np.flatnonzero(ok)
    if len(clear) == 0:
        return lo, lo
    if (clear[0] > 0 or clear[-1] < len(ok) - 1) and not ok[clear[0] : clear[-1] + 1].all():
        # trimmed, and the room lies behind it between its ends as well: a furniture face standing in the
        # room in line with a wall hidden behind it (a wardrobe's front before an inner wall), not a wall
        return lo, lo
    return float(edges[clear[0]]), min(float(edges[clear[-1] + 1]), hi)


def _side_within(
    points: NDArray, normal: NDArray, offset: float, horiz: NDArray, lo: float, hi: float, cfg: SegmentConfig
) -> NDArray[np.float64]:
    """Signed distances (m, positive towards the room) from a wall plane (``normal`` [3], ``offset``) of the
    points [k, 3] lying along its stretch [lo, hi] (m along ``horiz`` [3]), kept two ``wall_bin`` inside its
    ends (the perpendicular wall at an inner corner stands right there)."""
    along = points @ horiz
    within = (along > lo + 2 * cfg.wall_bin) & (along < hi - 2 * cfg.wall_bin)
    return points[within] @ normal + offset


def _share_behind(side: NDArray, cfg: SegmentConfig) -> float:
    """Share of the signed distances ``side`` [k] (``_side_within``) behind the plane by more than two
    ``plane_distance``; 1 when there are none."""
    return float((side < -cfg.plane_distance * 2).mean()) if len(side) else 1.0


def _structure(
    verts: NDArray, normals: NDArray, cams: NDArray, cfg: SegmentConfig
) -> tuple[NDArray[np.int64], list[dict[str, Any]]]:
    """Structure label per vertex (0 none, 1 floor, 2.. walls, then ceiling) and the planes found."""
    import open3d as o3d

    labels = np.zeros(len(verts), np.int64)
    labels[verts[:, 2] < cfg.floor_band] = 1
    planes: list[dict[str, Any]] = [{"kind": "floor", "id": 1, "vertices": int((labels == 1).sum())}]
    cos_n = np.cos(np.radians(cfg.plane_normal_deg))
    sin_v = np.sin(np.radians(cfg.vertical_tolerance_deg))
    top_cam = float(cams[:, 2].max()) if len(cams) else 0.0
    centre = cams.mean(axis=0) if len(cams) else verts.mean(axis=0)
    free = labels == 0
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[free]))
    pcd = pcd.voxel_down_sample(cfg.plane_voxel)
    thin = np.asarray(pcd.points)
    rest = pcd
    next_id = 2
    walls: list[tuple[NDArray, float, NDArray, float, float]] = []
    ceiling: float | None = None
    for _ in range(cfg.max_planes):
        if len(rest.points) < 200:
            break
        (a, b, c, d), inl = rest.segment_plane(cfg.plane_distance, 3, cfg.plane_iterations)
        n = np.array([a, b, c])
        n, d = n / np.linalg.norm(n), d / np.linalg.norm(n)
        pts = np.asarray(rest.points)[inl]
        rest = rest.select_by_index(inl, invert=True)
        if len(inl) < 200:
            break
        if n @ (centre - 0) + d < 0:  # orient towards the cameras (into the room)
            n, d = -n, -d
        if abs(n[2]) < sin_v:
            horiz = np.cross(n, [0.0, 0.0, 1.0])
            horiz /= np.linalg.norm(horiz)
            lo, hi = _wall_span(pts @ horiz, cfg.wall_bin)
            on_wall = (pts @ horiz >= lo) & (pts @ horiz <= hi)
            height = float(np.ptp(pts[on_wall, 2]))
            # only what lies behind the wall's own span counts: in an L-shaped room the other arm lies
            # behind the plane of an inner wall, beside the wall itself
            side = _side_within(thin, n, d, horiz, lo, hi, cfg)
            if (side < -cfg.plane_distance * 2).sum() > (side > cfg.plane_distance * 2).sum():
                # the room lies on the other side (the cameras' centre can lie outside an L-shaped room's arm)
                n, d, horiz, side = -n, -d, -horiz, -side
                lo, hi = -hi, -lo
            behind = _share_behind(side, cfg)
            if behind > cfg.wall_max_behind:
                # an inner wall whose plane runs on across the room's other arm: its stretch less the ends
                # with the room behind them
                lo, hi = _trim_overhang(thin @ horiz, thin @ n + d, lo, hi, cfg)
                behind = _share_behind(_side_within(thin, n, d, horiz, lo, hi, cfg), cfg)
            # a face parallel to a wall just in front of it is furniture against the wall (a wardrobe's front)
            # (measured at its own inliers: a plane tilted a degree off the wall it parallels crosses it)
            shadow = any(
                n @ w[0] > 0.98 and -cfg.plane_distance < np.median(pts[on_wall] @ w[0] + w[1]) < cfg.wall_shadow
                for w in walls
            )
            if (
                hi - lo >= cfg.wall_min_extent
                and height >= cfg.wall_min_extent
                and behind <= cfg.wall_max_behind
                and not shadow
            ):
                walls.append((n, d, horiz, lo, hi))
        elif abs(n[2]) > np.cos(np.radians(cfg.vertical_tolerance_deg)):
            z = float(np.median(pts[:, 2]))
            if z > top_cam + cfg.ceiling_min_above_cameras and (ceiling is None or z > ceiling):
                ceiling = z
    found_by = "plane"
    if ceiling is None:
        # left out, the strips of ceiling the cameras did see become object segments
        ceiling, found_by = _ceiling_slab(verts[free], normals[free], top_cam, cfg), "downward slab"
    for n, d, horiz, lo, hi in walls:
        along = verts @ horiz
        on = free & (np.abs(verts @ n + d) < cfg.plane_distance) & (np.abs(normals @ n) > cos_n)
        on &= (along >= lo - cfg.plane_distance) & (along <= hi + cfg.plane_distance)
        labels[on] = next_id
        planes.append({"kind": "wall", "id": next_id, "normal": n.round(4).tolist(), "offset": round(float(d), 4),
                       "span": [round(float(lo), 4), round(float(hi), 4)], "vertices": int(on.sum())})  # fmt: skip
        free &= ~on
        next_id += 1
    if ceiling is not None:
        z = ceiling
        on = free & (verts[:, 2] > z - cfg.plane_distance) & (np.abs(normals[:, 2]) > cos_n)
        on |= free & (verts[:, 2] > z + cfg.plane_distance)
        labels[on] = next_id
        planes.append(
            {"kind": "ceiling", "id": next_id, "height": round(z, 4), "vertices": int(on.sum()), "found_by": found_by}
        )
    return labels, planes


def _ceiling_slab(verts: NDArray, normals: NDArray, top_cam: float, cfg: SegmentConfig) -> float | None:
    """Height (m) of a ceiling too little seen for the plane search, from mesh vertices [v, 3] and their unit
    normals [v, 3] (world frame, z up) off the floor: the median height of the downward-facing vertices
    (within ``vertical_tolerance_deg`` of down) in the slab within ``plane_distance`` of a height that holds
    the most of them, above ``top_cam`` (the highest camera, m) by ``ceiling_min_above_cameras``. None when
    that slab holds fewer than ``ceiling_min_vertices`` or as many vertices lie above it."""
    band = cfg.plane_distance
    down = normals[:, 2] < -np.cos(np.radians(cfg.vertical_tolerance_deg))
    z = np.sort(verts[down & (verts[:, 2] > top_cam + cfg.ceiling_min_above_cameras), 2])
    if len(z) < cfg.ceiling_min_vertices:
        return None
    heights = np.arange(z[0], z[-1] + 0.01, 0.01)  # 1 cm steps
    counts = np.searchsorted(z, heights + band, "right") - np.searchsorted(z, heights - band, "left")
    best = int(np.argmax(counts))
    if counts[best] < cfg.ceiling_min_vertices:
        return None
    height = float(np.median(z[np.abs(z - heights[best]) <= band]))
    if int((verts[:, 2] > height + band).sum()) >= cfg.ceiling_min_vertices:
        return None  # something stands above it: the underside of a thing hanging in the room
    return height


@dataclass
class ScanPoints:
    """The fused surface off the floor and ceiling, thinned, with its superpoints.

    points, normals (unit), colours (RGB in [0, 1]): [n, 3], world frame. wall: [n] id of the wall plane the
    point lies on (0: none). vertex_point: [v] the point each mesh vertex maps to (-1: none, e.g. floor).
    edges: [e, 2] the point graph; concave, colour_step: [e] each edge's concave crease and colour step
    (``edge_weights``), fixed with the points whatever superpoints they fall in. graph: the superpoints and
    their contacts."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    colours: NDArray[np.float64]
    wall: NDArray[np.int64]
    vertex_point: NDArray[np.int64]
    edges: NDArray[np.int64]
    concave: NDArray[np.bool_]
    colour_step: NDArray[np.float64]
    graph: SuperpointGraph


def scan_points(
    verts: NDArray, normals: NDArray, colours: NDArray, struct: NDArray[np.int64], planes: list[dict[str, Any]],
    cfg: SegmentConfig, fh_k: float | None = None,
) -> ScanPoints:  # fmt: skip
    """Thin the free and wall vertices (each wall on its own, so a point is either on a wall or not) to
    ``superpoint_voxel`` and over-segment them into superpoints (``rescene_core.segment.superpoints``) at
    the scale ``fh_k`` (default ``cfg.fh_k``)."""
    import open3d as o3d

    groups = [0] + [int(p["id"]) for p in planes if p["kind"] == "wall"]
    pts, nrm, col, wall = [], [], [], []
    vertex_point = np.full(len(verts), -1, np.int64)
    offset = 0
    for gid in groups:
        sel = np.flatnonzero(struct == gid)
        if len(sel) == 0:
            continue
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(verts[sel]))
        pcd.normals = o3d.utility.Vector3dVector(normals[sel])
        pcd.colors = o3d.utility.Vector3dVector(np.clip(colours[sel], 0.0, 1.0))
        pcd = pcd.voxel_down_sample(cfg.superpoint_voxel)
        p = np.asarray(pcd.points)
        near = cKDTree(p).query(verts[sel], k=1)[1]
        vertex_point[sel] = offset + near
        pts.append(p)
        nrm.append(np.asarray(pcd.normals))
        col.append(np.asarray(pcd.colors))
        wall.append(np.full(len(p), gid, np.int64))
        offset += len(p)
    if not pts:
        raise SegmentError("nothing is left off the floor and ceiling to segment (the scan shows no objects or walls)")
    P, N, C, Wl = np.concatenate(pts), np.concatenate(nrm), np.concatenate(col), np.concatenate(wall)
    N = N / np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-9)
    edges = point_graph(P, cfg.superpoint_voxel * cfg.graph_radius_voxels)
    weights, concave, step = edge_weights(P, N, C, edges, cfg.fh_colour_weight)
    label = felzenszwalb(len(P), edges, weights, cfg.fh_k if fh_k is None else fh_k, cfg.fh_min_size)
    graph = superpoint_graph(P, N, C, label, edges, concave, step)
    return ScanPoints(P, N, C, Wl, vertex_point, edges, concave, step, graph)


def points_by_region(point_region: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The point indices sorted by region (``point_region`` [k], ids below ``n``) and where each region's run
    starts [n + 1]: region r's points are ``order[start[r] : start[r + 1]]``."""
    order = np.argsort(point_region, kind="stable")
    return order, np.searchsorted(point_region[order], np.arange(n + 1))


def _point_parts(
    edges: NDArray[np.int64], mask: NDArray[np.bool_], keep: NDArray[np.bool_] | None = None
) -> tuple[int, NDArray[np.int64]]:
    """Connected parts of the points ``mask`` [n] over the point graph's ``edges`` [e, 2] joining two of them
    (and ``keep`` [e] when given): how many, and the part of each point [n] (0..k-1; -1 outside the mask)."""
    i0, i1 = edges[:, 0], edges[:, 1]
    join = mask[i0] & mask[i1] if keep is None else mask[i0] & mask[i1] & keep
    local = np.cumsum(mask) - 1  # index among the masked points
    m = int(mask.sum())
    adj = coo_matrix((np.ones(int(join.sum())), (local[i0[join]], local[i1[join]])), shape=(m, m))
    k, sub = connected_components(adj, directed=False)
    part = np.full(len(mask), -1, np.int64)
    part[mask] = sub
    return int(k), part


def _components(n: int, pairs: NDArray[np.int64], keep: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Connected component [n] of the graph with the ``keep`` pairs as edges."""
    e = pairs[keep]
    adj = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    return np.asarray(connected_components(adj, directed=False)[1], np.int64)


def wall_superpoints(
    sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Per superpoint: the wall it lies on (0: none; the wall of most of its points) and whether it is a
    flush object on that wall (its colour differs from the wall's, or it stands proud of the plane)."""
    g = sp.graph
    n = g.size
    on = np.bincount(g.label, (sp.wall > 0).astype(float), n) / np.maximum(g.count, 1)
    which = np.zeros(n, np.int64)
    if (sp.wall > 0).any():
        key = g.label[sp.wall > 0] * (int(sp.wall.max()) + 1) + sp.wall[sp.wall > 0]
        uk, cnt = np.unique(key, return_counts=True)
        order = np.lexsort((-cnt, uk // (int(sp.wall.max()) + 1)))
        first_sp = uk[order] // (int(sp.wall.max()) + 1)
        first = np.r_[True, first_sp[1:] != first_sp[:-1]] if len(first_sp) else np.zeros(0, bool)
        which[first_sp[first]] = uk[order][first] % (int(sp.wall.max()) + 1)
    which[on < 0.5] = 0
    flush = np.zeros(n, bool)
    extent = (g.hi - g.lo).max(axis=1)
    # a superpoint that reaches down to the floor or up to the ceiling is no part of a flush object (a door
    # beside a mirror, of the wood of its frame, would otherwise take the mirror into the wall)
    hangs = (g.lo[:, 2] >= cfg.flush_min_height) & (g.hi[:, 2] <= _ceiling_height(planes) - cfg.flush_ceiling_gap)
    paint = wall_colours(sp)
    for plane in planes:
        if plane["kind"] != "wall":
            continue
        mine = sp.wall == plane["id"]
        if not mine.any():
            continue
        wall_colour = paint[int(plane["id"])]
        proud = np.bincount(g.label[mine], sp.points[mine] @ np.asarray(plane["normal"]) + plane["offset"], n)
        proud = proud / np.maximum(np.bincount(g.label[mine], minlength=n), 1)
        cand = (which == plane["id"]) & (~_of_paint(g.colour, wall_colour, cfg) | (proud >= cfg.flush_offset))
        flush |= cand & hangs & (extent <= cfg.flush_max_extent)
    # a hanging superpoint off every plane but lying wholly within ``structure_band`` in front of a wall,
    # along its stretch, is a piece of something hung on it (a clock's rim and face stand 2-4 cm proud,
    # beyond the plane's reach): a flush candidate on that wall, so its pieces join as one
    near = _near_wall(sp, planes, cfg)
    off = (which == 0) & (near > 0) & hangs & (extent <= cfg.flush_max_extent)
    which[off] = near[off]
    flush |= off
    return which, flush


def wall_colours(sp: ScanPoints) -> dict[int, NDArray[np.float64]]:
    """The colour [3] (RGB in [0, 1]) of each wall (by id) that scan points lie on: their median colour."""
    return {int(w): np.median(sp.colours[sp.wall == w], axis=0) for w in np.unique(sp.wall[sp.wall > 0])}


def _of_paint(colours: NDArray, wall_colour: NDArray, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Whether each colour [s, 3] (RGB in [0, 1]) is its wall's paint [3]: within ``flush_colour_step`` of it
    (RGB distance / sqrt 3) or the paint darkened (``_shaded``). The wall in a shadow (under a wall shelf,
    behind furniture) differs in colour but is no picture: taken as one, it joins the shelf casting it and
    buries the shelf in wall."""
    step = np.linalg.norm(colours - wall_colour, axis=1) / np.sqrt(3.0)
    return (step < cfg.flush_colour_step) | _shaded(colours, wall_colour, cfg.flush_shadow_tint)


def _shaded(colours: NDArray, wall_colour: NDArray, tint: float) -> NDArray[np.bool_]:
    """Whether each colour [s, 3] (RGB in [0, 1]) is the wall's colour [3] darkened: a multiple k < 1 of it
    leaves less than ``tint`` (RGB distance / sqrt 3) of the colour unexplained (a shadow keeps the hue)."""
    k, rest = _hue_rest(colours, wall_colour)
    return (k < 1.0) & (rest < tint)


def _hue_rest(colours: NDArray, reference: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each colour [n, 3] (RGB in [0, 1]), the multiple k [n] of ``reference`` [3] nearest to it and what
    is left of it after that multiple is taken off [n] (RGB distance / sqrt 3): 0 for the reference lit or
    shaded, more as the hue departs from it."""
    k = colours @ reference / max(float(reference @ reference), 1e-9)
    return k, np.linalg.norm(colours - k[:, None] * reference, axis=1) / np.sqrt(3.0)


def _near_wall(sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig) -> NDArray[np.int64]:
    """Per superpoint [s]: the wall (id) all of whose points lie within ``structure_band`` in front of its
    plane and along its stretch, 0 when none."""
    g = sp.graph
    n = g.size
    near = np.zeros(n, np.int64)
    for plane in planes:
        if plane["kind"] != "wall":
            continue
        normal = np.asarray(plane["normal"])
        horiz = np.cross(normal, [0.0, 0.0, 1.0])
        horiz /= np.linalg.norm(horiz)
        dist = sp.points @ normal + plane["offset"]
        along = sp.points @ horiz
        lo, hi = plane["span"]
        inside = (dist > -cfg.plane_distance) & (dist < cfg.structure_band) & (along >= lo) & (along <= hi)
        outside_count = np.bincount(g.label, (~inside).astype(float), n)
        near[(outside_count == 0) & (near == 0)] = int(plane["id"])
    return near


def _ceiling_height(planes: list[dict[str, Any]]) -> float:
    """Height of the ceiling plane (m), infinite when none was found."""
    ceiling = [float(p["height"]) for p in planes if p["kind"] == "ceiling"]
    return ceiling[0] if ceiling else float(np.inf)


def _support_cut(
    g: SuperpointGraph, a: NDArray[np.int64], b: NDArray[np.int64], cfg: SegmentConfig
) -> NDArray[np.bool_]:
    """Whether superpoint b stands on a (a is a horizontal top above ``support_min_height`` and b rises
    from its height) and is narrower than it both ways (what spans the top is the piece's own back)."""
    top_z = g.centroid[a, 2]
    is_top = (g.up[a] >= cfg.support_up_share) & (top_z >= cfg.support_min_height)
    rises = (g.lo[b, 2] >= top_z - cfg.support_band) & (g.centroid[b, 2] > top_z + cfg.support_band)
    span_top = g.hi[a, :2] - g.lo[a, :2]
    span_b = g.hi[b, :2] - g.lo[b, :2]
    spans = (span_b >= cfg.support_span_fraction * span_top).any(axis=1)
    return is_top & rises & ~spans


def merge_superpoints(
    sp: ScanPoints, planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], dict[str, Any]]:
    """The scan points (their superpoints split where a body stands on a top: ``split_bodies_on_tops``),
    the object region [s] of each superpoint (0: none) and its wall [s] (0: none), from geometry and colour
    alone (see the module docstring), with counts for the report."""
    g = sp.graph
    n = g.size
    which, flush = wall_superpoints(sp, planes, cfg)
    free = (which == 0) | flush
    a, b = g.pairs[:, 0], g.pairs[:, 1]
    crease = g.concave / np.maximum(g.contacts, 1) >= cfg.concave_fraction
    colour = np.linalg.norm(g.colour[a] - g.colour[b], axis=1) / np.sqrt(3.0)
    support = _support_cut(g, a, b, cfg) | _support_cut(g, b, a, cfg)
    join = free[a] & free[b] & (g.contacts >= cfg.min_contacts)
    cut_crease = join & crease & (colour >= cfg.concave_colour_step)
    cut_colour = join & (colour >= cfg.colour_cut)
    cut_support = join & support
    join &= ~(cut_crease | cut_colour | cut_support)
    comp = _components(n, g.pairs, join)
    region = np.where(free, comp + 1, 0)
    stats = {
        "superpoints": int(n),
        "contacts": int(len(g.pairs)),
        "cut_crease": int(cut_crease.sum()),
        "cut_colour": int(cut_colour.sum()),
        "cut_support": int(cut_support.sum()),
        "flush_superpoints": int(flush.sum()),
    }
    # flush pieces on one wall parted by colour join when one lies within the other's bounds: a picture's
    # canvas in its frame, a mirror's glass in its frame, a clock's face in its rim (a clock hung just above
    # a picture lies beside it and stays apart)
    hung = flush[a] & flush[b] & (which[a] == which[b]) & (g.contacts >= cfg.min_contacts) & ~join
    region, stats["rejoined_flush"] = _rejoin_enclosed(sp, region, hung, np.zeros(n, bool), cfg, by_extent=True)
    region = _absorb_small(g, region, cfg)
    region, stats["legs_attached"] = _attach_legs(sp, region, cfg)
    region, stats["backs_attached"] = _attach_backs(sp, region, planes, cfg)
    near_structure = _structure_distance(g.centroid, planes) < cfg.structure_band
    region, stats["rejoined_enclosed"] = _rejoin_enclosed(
        sp, region, cut_crease & ~cut_colour & ~cut_support, near_structure, cfg
    )
    region, stats["stems_joined"] = _join_stems(sp, region, cfg, planes)
    region, stats["brackets_joined"] = _join_brackets(sp, region, cfg, planes)
    region, stats["rows_joined"] = _join_stored_rows(sp, region, cfg)
    sp, region, which, stats["parted_from_wall"] = part_from_wall_stretch(sp, region, which, planes, cfg)
    split_from = int(region.max(initial=0)) + 1
    sp, region, which, stats["split_from_tops"] = split_bodies_on_tops(sp, region, which, cfg)
    sp, region, which, stats["stacks_split"] = split_stacked(sp, region, which, cfg)
    # a lamp's base that ``_absorb_small`` gave to its nightstand came back off the top as a body of its own:
    # now under its shade as a stem is
    region, stats["stems_rejoined"] = _join_stems(sp, region, cfg, planes, split_from)
    region, stats["bedding_joined"] = _join_bedding(sp, region, cfg)
    sp, region, which, stats["wall_points_taken_off"] = take_off_wall_paint(sp, region, which, planes, cfg)
    region, drop = _filter_regions(sp, region, which, planes, cfg)
    stats.update(drop)
    return sp, region, which, stats


def _top_heights(z: NDArray[np.float64], cfg: SegmentConfig, min_height: float) -> list[float]:
    """Heights (m) of the horizontal tops among upward-facing points at heights ``z`` [k]: 1 cm bins with
    at least ``top_min_points`` points in a bin and its two neighbours, each the highest-count bin of its
    own neighbourhood, above ``min_height``."""
    z = z[z >= min_height]
    if len(z) < cfg.top_min_points:
        return []
    edges = np.arange(z.min() - 0.005, z.max() + 0.015, 0.01)
    hist = np.histogram(z, edges)[0]
    slab = hist + np.r_[0, hist[:-1]] + np.r_[hist[1:], 0]
    peak = (slab >= cfg.top_min_points) & (slab >= np.r_[0, slab[:-1]]) & (slab > np.r_[slab[1:], 0])
    out = []
    for i in np.flatnonzero(peak).tolist():
        near = np.abs(z - 0.5 * (edges[i] + edges[i + 1])) <= 0.015
        out.append(float(np.median(z[near])))
    return out


def split_bodies_on_tops(
    sp: ScanPoints, region: NDArray[np.int64], which: NDArray[np.int64], cfg: SegmentConfig
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """Bodies standing on a horizontal top of their region are split off it at the top's plane: a monitor
    on a desk (its base plate rises 3-7 cm, no crease and no colour step parts it), a lamp whose base disc
    fused into the top's superpoint, a book stack on a table.

    For each region (``region`` [s], 0: none) and each top of it (``_top_heights``: a slab of upward-facing
    points above ``support_min_height``), the region's points more than ``top_clearance`` above the top and
    over its bounds fall into connected parts of the point graph. A part is a body on the top when it has
    ``min_segment_points`` points, begins within ``support_band`` of the top, touches nothing of its region
    below the top (a side panel or a leg does), is narrower than ``support_span_fraction`` of the top both
    ways (a chair's back or a headboard spans its seat) and the top reaches beyond its footprint by
    ``top_margin`` on ``top_sides`` sides or more of the four (x and y in the aligned frame). Before that,
    pieces standing on the floor beside a high top are parted from it (``_pieces_beside_top``: chairs at a
    table); after it, the parts joined to the region below the top, and those that failed the body test,
    are searched for bodies stored on the top (``_stored_bodies``: a case's frame over its shelf holds
    them). Superpoints a body cuts are split. ``which`` [s]: the wall of each superpoint (0: none). Returns
    the scan points with the new superpoint graph, the region and wall of each new superpoint, and how
    many bodies and pieces were split."""
    g = sp.graph
    point_region = region[g.label].copy()
    up = _facing_up(sp.normals)
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    nxt = int(region.max(initial=0)) + 1
    split = 0
    off_wall = which[g.label] == 0  # a wall patch the region took in is neither a top nor a body
    z = sp.points[:, 2]
    for r in range(1, int(region.max(initial=0)) + 1):
        mine = (point_region == r) & off_wall
        if mine.sum() < 2 * cfg.min_segment_points:
            continue
        for h in _top_heights(z[mine & up], cfg, min(cfg.support_min_height, cfg.stored_min_height)):
            mine = (point_region == r) & off_wall
            slab = mine & up & (np.abs(z - h) <= cfg.support_band / 2)
            if slab.sum() < cfg.top_min_points:
                continue
            beside = _pieces_beside_top(sp, mine, slab, h, cfg)
            for piece in beside:
                point_region[piece] = nxt
                nxt += 1
                split += 1
            if beside:
                mine = (point_region == r) & off_wall
                slab &= mine
            tlo, thi = sp.points[slab, :2].min(axis=0), sp.points[slab, :2].max(axis=0)
            above = mine & (z > h + cfg.top_clearance)
            if above.sum() < cfg.min_segment_points:
                continue
            below = mine & (z < h - cfg.top_clearance)
            _, comp = _point_parts(sp.edges, above)
            # parts touching the region below the top (a leg, a side panel, a hutch's sides) are no bodies on it
            down = np.unique(np.r_[comp[i0[above[i0] & below[i1]]], comp[i1[above[i1] & below[i0]]]])
            ids, counts = np.unique(comp[above], return_counts=True)
            frame = list(down)  # parts of the piece's own above the top, which may hold stored bodies
            for c in ids[counts >= cfg.min_segment_points].tolist():
                if c in down or h < cfg.support_min_height:
                    continue
                body = above & (comp == c)
                p = sp.points[body]
                lo, hi = p.min(axis=0), p.max(axis=0)
                centre = p[:, :2].mean(axis=0)
                if lo[2] > h + cfg.support_band or np.any(centre < tlo) or np.any(centre > thi):
                    continue  # it does not stand on the top (a shelf board over it, a part beside it)
                foot = p[p[:, 2] <= lo[2] + cfg.foot_height]
                if not _held_by_top(lo, hi, sp.points[slab, :2], cfg, foot.min(axis=0), foot.max(axis=0)):
                    frame.append(c)  # a chair's back, a headboard, a hutch, a case's frame over its shelf
                    continue
                point_region[body] = nxt
                nxt += 1
                split += 1
            # what the region's frame holds fast above the top, or all above a top too low to carry bodies
            # of their own: a body stored on the shelf of a case
            stuck = above & (np.isin(comp, frame) | (h < cfg.support_min_height)) & (point_region == r)
            for body in _stored_bodies(sp, stuck, mine & (z < h - cfg.support_band), mine, h, slab, cfg):
                point_region[body] = nxt
                nxt += 1
                split += 1
    return _regrouped(sp, region, which, point_region, split)


def part_from_wall_stretch(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """What stands against a stretch of wall its plane did not claim, parted from it. The stretch (a region at
    least ``wall_piece_height`` tall with ``structure_sliver_fraction`` of its points within
    ``structure_band`` of the structure planes) would be dropped whole as a sliver of the wall, and with it
    the desk joined to it; each connected part of its points at least ``stands_out`` off every plane,
    with ``min_segment_points`` points and ``min_segment_extent`` long, becomes a region of its own. The
    part's points nearer the wall stay with the stretch. ``region`` [s] (0: none), ``which`` [s]: the wall
    of each superpoint (0: none). Returns the scan points with the new superpoint graph, the region and
    wall of each new superpoint, and how many parts were parted."""
    point_region = region[sp.graph.label].copy()
    n = int(region.max(initial=0)) + 1
    order, bounds = points_by_region(point_region, n)
    nxt, parted = n, 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < cfg.min_segment_points or np.ptp(sp.points[idx, 2]) < cfg.wall_piece_height:
            continue
        dist = _structure_distance(sp.points[idx], planes)
        if not _mostly_structure(dist, cfg):
            continue
        off = np.zeros(len(sp.points), bool)
        off[idx[dist >= cfg.stands_out]] = True
        if off.sum() < cfg.min_segment_points:
            continue
        _, part = _point_parts(sp.edges, off)
        ids, counts = np.unique(part[off], return_counts=True)
        for c in ids[counts >= cfg.min_segment_points].tolist():
            mine = part == c
            if float(np.ptp(sp.points[mine], axis=0).max()) >= cfg.min_segment_extent:
                point_region[mine] = nxt
                nxt += 1
                parted += 1
    return _regrouped(sp, region, which, point_region, parted)


def take_off_wall_paint(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """An object's region with the points of the wall's paint taken off. A superpoint holding both wall and
    free points (the wall in a wall shelf's shadow fused with the shelf's brackets) is the wall's only when
    most of its points are, so an object's region takes in wall points with it. In a region under half on
    walls (no flush object), the points on a wall's plane (``ScanPoints.wall``) of its colour (a step under
    ``flush_colour_step``) or of its colour darkened (a shadow) are taken off (``_of_paint``, as
    ``wall_superpoints`` judges a superpoint). ``region`` [s] (0: none), ``which`` [s]: the wall of each
    superpoint (0: none). Returns the scan points with the new superpoint graph, the region and wall of
    each new superpoint, and how many points were taken off."""
    point_region = region[sp.graph.label].copy()
    n = int(region.max(initial=0)) + 1
    paint = wall_colours(sp)
    order, bounds = points_by_region(point_region, n)
    taken = 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        on = idx[sp.wall[idx] > 0]
        if len(on) == 0 or 2 * len(on) >= len(idx):
            continue
        if _out_from_wall(sp.points[idx], planes) < cfg.stands_out:
            continue  # hung flat on the wall (a clock, its face of the wall's white): the flush tests judge it
        if _mostly_structure(_structure_distance(sp.points[idx], planes), cfg):
            continue  # a sliver of the structure, dropped whole; without its paint it would no longer look one
        for w in np.unique(sp.wall[on]).tolist():
            mine = on[sp.wall[on] == w]
            plain = mine[_of_paint(sp.colours[mine], paint[w], cfg)]
            point_region[plain] = 0
            taken += len(plain)
    return _regrouped(sp, region, which, point_region, taken)


def _regrouped(
    sp: ScanPoints, region: NDArray[np.int64], which: NDArray[np.int64], point_region: NDArray[np.int64], changed: int
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """What a step that moved points between regions returns: the scan points regrouped by the new
    ``point_region`` [n] (``regroup``) with the region and wall of each new superpoint, and ``changed``
    (how many it split, parted or took off); all as they were when it changed nothing."""
    if changed == 0:
        return sp, region, which, 0
    sp, region, parent = regroup(sp, point_region)
    return sp, region, which[parent], changed


def regroup(sp: ScanPoints, point_region: NDArray[np.int64]) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64]]:
    """The scan points regrouped after regions were split across superpoints: each superpoint cut in as
    many as the regions of its points (``point_region`` [n]). Returns the scan points with the new
    superpoint graph, the region [s'] of each new superpoint and the superpoint [s'] it was cut from (to
    carry what each superpoint holds, such as its wall)."""
    nxt = int(point_region.max(initial=0)) + 1
    key = sp.graph.label * nxt + point_region
    uk, label = np.unique(key, return_inverse=True)
    graph = superpoint_graph(
        sp.points, sp.normals, sp.colours, label.astype(np.int64), sp.edges, sp.concave, sp.colour_step
    )
    return replace(sp, graph=graph), (uk % nxt).astype(np.int64), (uk // nxt).astype(np.int64)


def split_stacked(
    sp: ScanPoints, region: NDArray[np.int64], which: NDArray[np.int64], cfg: SegmentConfig
) -> tuple[ScanPoints, NDArray[np.int64], NDArray[np.int64], int]:
    """A body resting on a narrower one, both small, is split off it at the height where the region
    narrows (``_stack_cut``): a book stack on a book stack. The upper stack's ring of the lower one's top
    is too narrow and too little seen to be a top (``split_bodies_on_tops``), but the step in width is
    plain. A region is a candidate when its lowest point is ``stacked_min_height`` high and it is at most
    ``stacked_max_width`` and at least ``min_segment_extent`` wide both ways. ``region`` [s] (0: none),
    ``which`` [s]: the wall of each superpoint (0: none). Returns the scan points with the new superpoint
    graph, the region and wall of each new superpoint, and how many bodies were split."""
    g = sp.graph
    point_region = region[g.label].copy()
    n = int(region.max(initial=0)) + 1
    order, bounds = points_by_region(point_region, n)
    nxt, split = n, 0
    for r in range(1, n):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < cfg.min_segment_points:
            continue
        p = sp.points[idx]
        lo, hi = p.min(axis=0), p.max(axis=0)
        wide = hi[:2] - lo[:2]
        if lo[2] < cfg.stacked_min_height or wide.max() > cfg.stacked_max_width or wide.min() < cfg.min_segment_extent:
            continue
        cut = _stack_cut(p, cfg)
        if cut is None:
            continue
        point_region[idx[p[:, 2] >= cut]] = nxt
        nxt += 1
        split += 1
    return _regrouped(sp, region, which, point_region, split)


def _stack_cut(p: NDArray, cfg: SegmentConfig) -> float | None:
    """The height (m) at which a small region's points ``p`` [k, 3] part into a body resting on a wider one,
    or None. Heights are tried every centimetre from ``stacked_min_part`` over the foot to as far under the
    top; at each, the narrowing is the larger of two ratios, each the widest of x and y: the extent of the
    points above over that of those below, and of the ``stacked_slice`` above over the slice below. The
    height of least narrowing is the cut when it is at most ``stacked_narrowing``, the centre of the points
    above lies over those below, both sides hold ``stacked_min_points`` (``min_segment_points`` below, so
    the lower body stays a segment) and each slice ``stacked_slice_points``, and the slice below is at most
    ``stacked_max_flare`` as wide as the ``stacked_slice`` at the foot (``_flares``)."""
    z = p[:, 2]
    foot = p[z < z.min() + cfg.stacked_slice, :2]
    best, cut = cfg.stacked_narrowing, None
    for h in np.arange(z.min() + cfg.stacked_min_part, z.max() - cfg.stacked_min_part + 1e-9, 0.01):
        below, above = p[z < h], p[z >= h]
        if len(below) < max(cfg.min_segment_points, cfg.stacked_min_points) or len(above) < cfg.stacked_min_points:
            continue
        under = below[below[:, 2] >= h - cfg.stacked_slice, :2]
        over = above[above[:, 2] < h + cfg.stacked_slice, :2]
        if min(len(under), len(over)) < cfg.stacked_slice_points:
            continue
        blo, bhi = below[:, :2].min(axis=0), below[:, :2].max(axis=0)
        whole = np.ptp(above[:, :2], axis=0) / np.maximum(bhi - blo, 1e-6)
        step = np.ptp(over, axis=0) / np.maximum(np.ptp(under, axis=0), 1e-6)
        narrowing = float(max(whole.max(), step.max()))
        centre = above[:, :2].mean(axis=0)
        if narrowing <= best and not _flares(under, foot, cfg) and np.all(centre > blo) and np.all(centre < bhi):
            best, cut = narrowing, float(h)
    return cut


def _flares(under: NDArray, foot: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a body flares out upward: the slice under a cut ``under`` [k, 2] (x, y, m) is more than
    ``stacked_max_flare`` as wide as the slice at its foot ``foot`` [f, 2], the wider of x and y (a pot under
    spreading foliage). A foot of fewer than ``stacked_slice_points`` points tells nothing."""
    if len(foot) < cfg.stacked_slice_points:
        return False
    return float(np.max(np.ptp(under, axis=0) / np.maximum(np.ptp(foot, axis=0), 1e-6))) > cfg.stacked_max_flare


def _footprint(top: NDArray, cell: float) -> tuple[float, Polygon]:
    """The footprint of a top from its upward-facing points ``top`` [k, 2] (x, y, m) on a grid of ``cell`` (m):
    the cells holding points, gaps of a cell closed and strips narrower than three cells opened away (the
    rail of a chair's back level with a table's top). Returns the footprint's area (m^2) and the smallest
    rectangle around the points in its cells: what stands on the top hides it, at its edges and corners too,
    and may part what is seen of it in two (a cabinet's top with book stacks across it)."""
    origin = top.min(axis=0) - 3 * cell
    ij = np.floor((top - origin) / cell).astype(np.int64)
    grid = np.zeros(tuple(ij.max(axis=0) + 4), bool)
    grid[ij[:, 0], ij[:, 1]] = True
    foot = ndimage.binary_opening(ndimage.binary_closing(grid), np.ones((3, 3), bool))
    if not foot.any():
        return 0.0, Polygon()
    return float(foot.sum()) * cell**2, MultiPoint(top[foot[ij[:, 0], ij[:, 1]]]).oriented_envelope


def _pieces_beside_top(
    sp: ScanPoints, mine: NDArray[np.bool_], slab: NDArray[np.bool_], h: float, cfg: SegmentConfig
) -> list[NDArray[np.bool_]]:
    """Pieces of a region standing on the floor beside one of its high tops, outside the top's footprint:
    chairs at a dining table or a desk, whose backs come within a few centimetres of its edge (the fused
    surface bridges the gap).

    ``mine`` [n]: the region's points; ``slab`` [n]: the top's upward-facing points at height ``h`` (m).
    The top must be ``beside_min_height`` high, ``beside_min_width`` wide both ways and its footprint
    (``_footprint``) as large as a square of that side. The region's points more than ``beside_margin``
    outside the footprint's outline fall into connected parts of the point graph; a part is a piece of its
    own when it has ``min_segment_points`` points, reaches down to ``beside_floor_gap`` over the floor, has
    ``beside_rise_points`` points ``beside_rise`` over the top, is ``beside_min_tall`` tall and
    ``beside_piece_width`` wide both ways, and holds fewer than ``top_min_points`` of the top's points.
    Returns the points [n] of each piece."""
    top = sp.points[slab, :2]
    if h < cfg.beside_min_height or np.min(top.max(axis=0) - top.min(axis=0)) < cfg.beside_min_width:
        return []
    area, outline = _footprint(top, 2.0 * cfg.superpoint_voxel)  # every cell of a top seen whole holds points
    if area < cfg.beside_min_width**2:
        return []  # too little of it seen to tell its outline
    out = mine.copy()
    out[mine] = ~shapely.contains_xy(outline.buffer(cfg.beside_margin), sp.points[mine, 0], sp.points[mine, 1])
    n_out = int(out.sum())
    if n_out < cfg.min_segment_points:
        return []
    _, comp = _point_parts(sp.edges, out)
    ids, counts = np.unique(comp[out], return_counts=True)
    pieces = []
    for c in ids[counts >= cfg.min_segment_points].tolist():
        piece = comp == c
        p = sp.points[piece]
        lo, hi = p.min(axis=0), p.max(axis=0)
        rises = int((p[:, 2] > h + cfg.beside_rise).sum()) >= cfg.beside_rise_points
        if lo[2] > cfg.beside_floor_gap or not rises or hi[2] - lo[2] < cfg.beside_min_tall:
            continue  # not on the floor (a lamp's shade over the edge), or lower than the top (a case's side)
        if np.min(hi[:2] - lo[:2]) >= cfg.beside_piece_width and (piece & slab).sum() < cfg.top_min_points:
            pieces.append(piece)
    return pieces


def _stored_bodies(
    sp: ScanPoints,
    stuck: NDArray[np.bool_],
    far_below: NDArray[np.bool_],
    mine: NDArray[np.bool_],
    h: float,
    slab: NDArray[np.bool_],
    cfg: SegmentConfig,
) -> list[NDArray[np.bool_]]:
    """Bodies stored on a shelf of a case, which the point graph joins to the case's back, sides or edges
    (a book stack against a bookcase's back panel, flush with the shelf's front edge).

    ``stuck`` [n]: the region's points above the top at height ``h`` (m) whose part of the point graph
    reaches below the top or failed the test of a body on the top (a case's frame over its shelf, joined
    to nothing under it, with the stacks touching it); ``far_below`` [n]: the region's points more than
    ``support_band`` under the top (a leg, a side panel); ``mine`` [n]: the region's points; ``slab`` [n]:
    the top's points. The stuck points in columns of the case's frame (``_frame_columns``: its sides and
    back) are left to the case, and the rest parted into bodies twice (``_parted_bodies``): first at their
    concave creases (``ScanPoints.concave``: a body meets the case's back and the board over it at a
    concave corner; its own faces meet at convex ones), then what is left also where the colour changes
    between the case's own (``case_tint`` off the shelf's median colour) and another: where the fused
    surface rounds a corner, no crease parts a stack from the panel it stands flush with, but its colour
    does. Creases come first because a book of the case's colour in a stack is parted from the other
    books by colour and stays with the case. Returns the points [n] of each body."""
    # the case's sides and back rise unbroken from the shelf: taken off the stuck points, they no longer
    # join the bodies they touch (a stack flush with a side panel or against the back)
    stuck = stuck & ~_frame_columns(sp.points, stuck, h, cfg)
    if int(stuck.sum()) < cfg.min_segment_points:
        return []
    case = sp.points[mine]
    bodies = _parted_bodies(sp, stuck, far_below, h, slab, case, cfg)
    left = stuck.copy()
    for body in bodies:
        left &= ~body
    if int(left.sum()) < cfg.min_segment_points:
        return bodies
    # the case's wood or paint, lit or shaded, against the colours of what is stored on it
    own = np.zeros(len(mine), bool)
    own[mine] = _hue_rest(sp.colours[mine], np.median(sp.colours[slab], axis=0))[1] < cfg.case_tint
    return bodies + _parted_bodies(sp, left, far_below, h, slab, case, cfg, own)


def _parted_bodies(
    sp: ScanPoints,
    stuck: NDArray[np.bool_],
    far_below: NDArray[np.bool_],
    h: float,
    slab: NDArray[np.bool_],
    case: NDArray,
    cfg: SegmentConfig,
    own: NDArray[np.bool_] | None = None,
) -> list[NDArray[np.bool_]]:
    """The bodies the ``stuck`` points [n] over a top at height ``h`` (m) part into at the concave creases
    and, with ``own`` [n] (each point of the case's colour or not), where that changes too (see
    ``_stored_bodies``; ``far_below``, ``slab`` as there; ``case`` [k, 3]: the case's points).

    A part beginning on the top and touching nothing far under it seeds a body, and the touching parts
    within its footprint grown by ``top_margin`` join it (the books of a stack, a stack on a stack). Parted
    by colour, a part of the other colour class joins only when it ends ``frame_column_rise`` over the top
    at most (a book of the case's colour in a stack, not a piece of the frame over it). A body is stored
    when it has ``min_segment_points`` points, its centre lies over the top's seen bounds, the top is seen
    beyond it on ``stored_top_sides`` sides (``_held_by_top``), it is ``body_min_thickness`` thick every
    way, is not upright (``_stored_upright``: a row of books standing in a bookcase is the bookcase's),
    nor, parted by colour, the case's own books (``_case_books``), and has a board of the case over
    ``stored_board_share`` of its footprint (``_board_share``; what has nothing over it, a sofa's back
    cushion, is the piece's own; parted by colour, only the case's colour is a board: a table seen over a
    chair's seat in one region is none). Returns the points [n] of each body."""
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    inner = stuck[i0] & stuck[i1]
    keep = ~sp.concave if own is None else ~sp.concave & (own[i0] == own[i1])
    boards = case if own is None else sp.points[own]  # ``own`` holds the case's points alone
    k, part = _point_parts(sp.edges, stuck, keep)
    sub = part[stuck]
    p = sp.points[stuck]
    lo = np.full((k, 3), np.inf)
    hi = np.full((k, 3), -np.inf)
    np.minimum.at(lo, sub, p)
    np.maximum.at(hi, sub, p)
    count = np.bincount(sub, minlength=k)
    held = np.zeros(k, bool)  # parts touching the region far under the top
    held[part[i0[stuck[i0] & far_below[i1]]]] = True
    held[part[i1[stuck[i1] & far_below[i0]]]] = True
    cross = inner & (part[i0] != part[i1])
    colour = np.zeros(k, bool)
    if own is not None:
        colour[sub] = own[stuck]  # one class a part: ``keep`` cuts where it changes
    neighbours: dict[int, set[int]] = {}
    for a, b in zip(part[i0[cross]].tolist(), part[i1[cross]].tolist(), strict=True):
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    top = sp.points[slab, :2]
    tlo, thi = top.min(axis=0), top.max(axis=0)
    seeds = np.flatnonzero(~held & (lo[:, 2] <= h + cfg.support_band) & (count >= cfg.min_contacts))
    taken = held.copy()
    bodies = []
    for s in seeds[np.argsort(-count[seeds], kind="stable")].tolist():
        if taken[s]:
            continue
        body, blo, bhi = [s], lo[s].copy(), hi[s].copy()
        frontier = [s]
        while frontier:
            grown = []
            for c in frontier:
                for t in neighbours.get(c, ()):
                    if taken[t] or t in body:
                        continue
                    within = np.all(lo[t, :2] >= blo[:2] - cfg.top_margin) & np.all(
                        hi[t, :2] <= bhi[:2] + cfg.top_margin
                    )
                    if within and (colour[t] == colour[s] or hi[t, 2] <= h + cfg.frame_column_rise):
                        body.append(t)
                        grown.append(t)
                        blo, bhi = np.minimum(blo, lo[t]), np.maximum(bhi, hi[t])
            frontier = grown
        blo[2] = h  # it stands on the top: its height counts from there
        if count[body].sum() < cfg.min_segment_points or float(np.min(bhi - blo)) < cfg.body_min_thickness:
            continue
        centre = 0.5 * (blo[:2] + bhi[:2])
        if (
            np.any(centre < tlo)
            or np.any(centre > thi)
            or not _held_by_top(blo, bhi, top, cfg, least=cfg.stored_top_sides)
        ):
            continue  # beside the shelf, the shelf seen nowhere beyond it, or spanned both ways
        points = np.isin(part, body)
        if own is not None and _case_books(sp, points, bhi[2] - blo[2], np.min(bhi[:2] - blo[:2]), cfg):
            continue  # parted by colour alone, upright or a row: the case's own books, a piece of its frame
        if _stored_upright(case, blo, bhi, cfg) and not _in_layers(sp, points, cfg):
            continue  # books standing in a row: the bookcase's own
        if _board_share(boards, blo, bhi, cfg) < cfg.stored_board_share:
            continue  # nothing of the case over it: a cushion against a sofa's back
        taken[body] = True
        bodies.append(points)
    return bodies


def _frame_columns(points: NDArray, stuck: NDArray[np.bool_], h: float, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Which of the ``stuck`` points [n] (``points`` [n, 3], m) stand in a column of the case's frame over its
    top at height ``h`` (m): a ``superpoint_voxel`` square column whose points fill every
    ``frame_column_bin`` of height, from its lowest point over ``top_clearance`` above the top up to
    ``frame_column_rise`` over the top, ``frame_column_least`` bins at least (a side or back panel rises
    unbroken past the shelf's bodies, seen from the shelf or only above what stands in front of it; a
    stack's column breaks between its top and the board over it)."""
    idx = np.flatnonzero(stuck)
    frame = np.zeros(len(points), bool)
    if len(idx) == 0:
        return frame
    q = points[idx]
    ij = np.floor(q[:, :2] / cfg.superpoint_voxel).astype(np.int64)
    ij -= ij.min(axis=0)
    _, column = np.unique(ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1], return_inverse=True)
    bins = int(round(cfg.frame_column_rise / cfg.frame_column_bin))
    level = np.floor((q[:, 2] - h - cfg.top_clearance) / cfg.frame_column_bin).astype(np.int64)
    within = (level >= 0) & (level < bins)
    filled = np.zeros((int(column.max()) + 1, bins), bool)
    filled[column[within], level[within]] = True
    # the bins filled without a break down from the top one, and the lowest bin filled at all: a panel seen
    # only above what stands in front of it runs unbroken from there
    run = np.cumprod(filled[:, ::-1], axis=1).sum(axis=1)
    first = np.argmax(filled, axis=1)
    frame[idx] = ((run == bins - first) & (run >= cfg.frame_column_least))[column]
    return frame


def _sides_beyond(lo: NDArray, hi: NDArray, top: NDArray, cfg: SegmentConfig) -> NDArray[np.bool_]:
    """Whether a top's points ``top`` [k, 2] (x, y, m) reach ``top_margin`` beyond the footprint ``lo``, ``hi``
    [>= 2] of what stands on it, ``min_contacts`` points each, on its four sides [4]: -x, +x, -y, +y."""
    inside_y = (top[:, 1] >= lo[1]) & (top[:, 1] <= hi[1])
    inside_x = (top[:, 0] >= lo[0]) & (top[:, 0] <= hi[0])
    return np.array([
        (inside_y & (top[:, 0] < lo[0] - cfg.top_margin)).sum(),
        (inside_y & (top[:, 0] > hi[0] + cfg.top_margin)).sum(),
        (inside_x & (top[:, 1] < lo[1] - cfg.top_margin)).sum(),
        (inside_x & (top[:, 1] > hi[1] + cfg.top_margin)).sum(),
    ]) >= cfg.min_contacts  # fmt: skip


def _held_by_top(
    lo: NDArray,
    hi: NDArray,
    top: NDArray,
    cfg: SegmentConfig,
    foot_lo: NDArray | None = None,
    foot_hi: NDArray | None = None,
    least: int | None = None,
) -> bool:
    """Whether a part above a top, with bounds ``lo``, ``hi`` [3] (m), stands on it as a body of its own
    rather than being the piece's own back: the top's upward-facing points ``top`` [k, 2] (x, y) reach
    ``top_margin`` beyond its foot (the bounds ``foot_lo``, ``foot_hi`` [>= 2] of what it stands on, by
    default its own: a lamp's shade overhangs its base, and a small nightstand's top reaches past the base
    but not the shade) on ``top_sides`` of its four sides (``_sides_beyond``), and it is
    narrower than ``support_span_fraction`` of the top both ways (a chair's back, a headboard, a hutch spans
    its seat, bed or desk one way and stands at its edge). A body spanning a narrow top one way only is its
    own when the top reaches beyond it on both sides the other way and it is ``body_min_thickness`` thick
    every way: a book stack as deep as the shelf it stands on, clear of the shelf's
    ends (a divider board across a desk is thinner). With ``least``, a body narrower than the top one way
    or both needs the top beyond its foot on that many sides only (a body stored under a board of its
    case, the shelf beyond it hidden)."""
    spans = hi[:2] - lo[:2] >= cfg.support_span_fraction * (top.max(axis=0) - top.min(axis=0))
    if spans.all():
        return False
    sides = _sides_beyond(lo if foot_lo is None else foot_lo, hi if foot_hi is None else foot_hi, top, cfg)
    if least is not None:
        return int(sides.sum()) >= least
    if not spans.any():
        return int(sides.sum()) >= cfg.top_sides
    across = sides[2:] if spans[0] else sides[:2]  # the two sides of the way it does not span
    return bool(across.all()) and float(np.min(hi - lo)) >= cfg.body_min_thickness


def _region_bounds(g: SuperpointGraph, region: NDArray[np.int64], n: int) -> tuple[NDArray, NDArray]:
    """Axis-aligned bounds ``lo``, ``hi`` [n, 3] (m) of each of ``n`` regions, from the bounds of the
    superpoints ``region`` [s] assigns to them (a region without superpoints: +inf, -inf)."""
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, region, g.lo)
    np.maximum.at(hi, region, g.hi)
    return lo, hi


def _rejoin_enclosed(
    sp: ScanPoints,
    region: NDArray[np.int64],
    creased: NDArray[np.bool_],
    near_structure: NDArray[np.bool_],
    cfg: SegmentConfig,
    by_extent: bool = False,
) -> tuple[NDArray[np.int64], int]:
    """Regions parted only by creases (``creased`` [p]: contacts cut for their concavity alone) join again
    when the smaller lies within the larger's bounds (``enclosed_fraction`` of its points by superpoint
    centroid): the shelves inside a bookcase's frame, the mattress inside a bed's frame. Nothing joins a
    region lying mostly along the structure (``near_structure`` [s]: superpoints by a wall, the floor or the
    ceiling), whose bounds span a wall, nor a region standing on a top of the larger one (``_rests_on``: a
    book stack on a shelf, a lamp on a nightstand). The smaller of two is the one with fewer points, or with
    ``by_extent`` the one with the shorter bounding-box diagonal (a picture's canvas has more points than
    its frame). Returns the regions and how many joined."""
    g = sp.graph
    region = region.copy()
    joined = 0
    up = _facing_up(sp.normals)
    for _ in range(3):
        n = int(region.max()) + 1
        lo, hi = _region_bounds(g, region, n)
        pts = np.bincount(region, g.count, n)
        along = np.bincount(region, g.count * near_structure, n) >= 0.5 * pts
        ra, rb = region[g.pairs[creased, 0]], region[g.pairs[creased, 1]]
        ok = (ra > 0) & (rb > 0) & (ra != rb)
        cand = {(min(a, b), max(a, b)) for a, b in zip(ra[ok].tolist(), rb[ok].tolist(), strict=True)}
        # the upward-facing points of each region, for the test of what stands on what
        point_region = region[g.label]
        up_idx = np.flatnonzero(up & (point_region > 0))
        up_idx = up_idx[np.argsort(point_region[up_idx], kind="stable")]
        up_bounds = np.searchsorted(point_region[up_idx], np.arange(n + 1))
        remap = np.arange(n)
        changed = False
        size = np.linalg.norm(hi - lo, axis=1) if by_extent else pts
        for a, b in sorted(cand):
            small, big = (a, b) if size[a] < size[b] else (b, a)
            if remap[small] != small or remap[big] != big or along[big] or along[small]:
                continue  # one of them joined another region in this round
            mine = region == small
            c = g.centroid[mine]
            inside = np.all((c >= lo[big]) & (c <= hi[big]), axis=1)
            if (g.count[mine] * inside).sum() < cfg.enclosed_fraction * pts[small]:
                continue
            tops = sp.points[up_idx[up_bounds[big] : up_bounds[big + 1]]]
            if not by_extent:
                case = sp.points[point_region == big]
                low = cfg.stored_min_height if _under_board(case, lo[small], hi[small], cfg) else cfg.support_min_height
                if _rests_on(tops, lo[small], hi[small], lo[big], hi[big], low, cfg):
                    if not _stored_upright(case, lo[small], hi[small], cfg):
                        continue  # a book stack on a shelf of its bookcase, a lamp on its nightstand
            remap[small] = big
            joined += 1
            changed = True
        region = remap[region]
        if not changed:
            break
    return region, joined


def _facing_up(normals: NDArray) -> NDArray[np.bool_]:
    """Whether each unit normal [k, 3] (z up) is within 15 degrees of up: the points of a horizontal top."""
    return normals[:, 2] > np.cos(np.radians(15.0))


def _touching_regions(
    g: SuperpointGraph, region: NDArray[np.int64], n: int, min_contacts: int, among: NDArray[np.bool_] | None = None
) -> list[tuple[int, int]]:
    """Pairs (a, b), a < b, of regions (``region`` [s] of each superpoint of graph ``g``, ids below ``n``, 0:
    none) whose superpoints touch with at least ``min_contacts`` graph contacts; with ``among`` [n], only
    pairs of which at least one region is marked."""
    ra, rb = region[g.pairs[:, 0]], region[g.pairs[:, 1]]
    ok = (ra > 0) & (rb > 0) & (ra != rb)
    if among is not None:
        ok &= among[ra] | among[rb]
    key = np.minimum(ra[ok], rb[ok]) * n + np.maximum(ra[ok], rb[ok])
    uk, inv = np.unique(key, return_inverse=True)
    contacts = np.bincount(inv, g.contacts[ok], len(uk))
    return [(k // n, k % n) for k in uk[contacts >= min_contacts].tolist()]


def _join_stems(
    sp: ScanPoints,
    region: NDArray[np.int64],
    cfg: SegmentConfig,
    planes: list[dict[str, Any]],
    split_from: int = 0,
) -> tuple[NDArray[np.int64], int]:
    """A region below another, its top between ``support_band`` above the other's lowest point and
    ``stem_gap`` under it, joins that one when its upper end (the points within ``support_band`` of its top)
    lies under the other's footprint (within ``stem_margin``) and is narrower than ``stem_width_fraction`` of
    the other both ways, and at least ``stem_overlap`` of its own footprint lies under the other's: a table
    lamp's base and stem under its shade, parted from it by the shade's colour and the crease at the rim, or
    by a gap where the fusion lost the stem's thin top (an angled arm, a base broader than the shade). A book
    stack under another has a top as broad as itself and stays apart. A region joins however broad its upper
    end when the other reaches ``top_margin`` past that end on every side (a plant's pot under its foliage)
    or when it hangs (``_hangs``: a wall shelf's bracket, parted from the board by its colour). What
    overhangs a region all round may begin lower than its top when what hangs that low lies beside the
    region, not over it (``_hangs_over``: leaves hanging beside the pot). With ``split_from`` > 0 (run
    after the splits, the first id of the bodies they split off) only those bodies join, and only as stems
    narrower than ``leg_width`` at their upper end, to regions numbered below it: a lamp's base and stem
    split off its nightstand's top join its shade; a stack split off a bookcase's shelf stays apart from
    the books standing on the board over it. ``region`` [s] (0: none); returns the regions and how many
    joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    point_region = region[g.label]
    gap = lo[None, :, 2] - hi[:, None, 2]  # [low, top]: from the low one's top up to the other's lowest point
    above = lo[:, None, 2] < lo[None, :, 2]
    under = (gap >= -cfg.support_band) & (gap <= cfg.stem_gap) & above
    # what overhangs a region all round may hang lower than the region's top beside it (foliage over its pot)
    around = (lo[None, :, :2] + cfg.top_margin <= lo[:, None, :2]).all(axis=2)
    around &= (hi[:, None, :2] <= hi[None, :, :2] - cfg.top_margin).all(axis=2)
    droop = around & (gap < -cfg.support_band) & above & (split_from == 0)
    under |= droop
    under[0, :] = under[:, 0] = False
    if split_from:
        under[:split_from, :] = under[:, split_from:] = False
    lows, tops = np.nonzero(under)
    cover = np.clip(np.minimum(hi[lows, :2], hi[tops, :2] + cfg.stem_margin)
                    - np.maximum(lo[lows, :2], lo[tops, :2] - cfg.stem_margin), 0.0, None).prod(axis=1)  # fmt: skip
    area = np.maximum(np.prod(hi[lows, :2] - lo[lows, :2], axis=1), 1e-6)
    keep = cover >= cfg.stem_overlap * area
    lows, tops = lows[keep], tops[keep]
    order = np.argsort(np.abs(gap[lows, tops]), kind="stable")  # the nearest one over it first
    by_region, start = points_by_region(point_region, n)
    remap = np.arange(n)
    joined = 0
    for low, top in zip(lows[order].tolist(), tops[order].tolist(), strict=True):
        if remap[low] != low or remap[top] != top:
            continue
        p = sp.points[by_region[start[low] : start[low + 1]]]
        end = p[p[:, 2] >= hi[low, 2] - cfg.support_band, :2]
        if droop[low, top] and _hangs_over(p, sp.points[by_region[start[top] : start[top + 1]]], hi[low, 2], cfg):
            continue  # what hangs lower than its top lies over it, not beside it
        end_lo, end_hi = end.min(axis=0), end.max(axis=0)
        if np.any(end_lo < lo[top, :2] - cfg.stem_margin) or np.any(end_hi > hi[top, :2] + cfg.stem_margin):
            continue  # its upper end reaches out from under the other (a floor lamp's arm beside a shelf)
        if split_from and np.any(end_hi - end_lo > cfg.leg_width):
            continue
        broad = np.any(end_hi - end_lo > cfg.stem_width_fraction * (hi[top, :2] - lo[top, :2]))
        # a plant's foliage overhangs its pot all round; a stack on a stack is no broader than the one under it
        overhung = split_from == 0 and bool(
            np.all(end_lo >= lo[top, :2] + cfg.top_margin) and np.all(end_hi <= hi[top, :2] - cfg.top_margin)
        )
        if broad and not overhung and not _hangs(sp, point_region, low, lo[low], hi[low], planes, cfg):
            continue  # a broad top: a body under the other (a book stack under another), not a stem
        remap[low] = top
        joined += 1
    return remap[region], joined


def _hangs_over(low: NDArray, top: NDArray, height: float, cfg: SegmentConfig) -> bool:
    """Whether ``min_contacts`` or more of the points ``top`` [k, 3] lower than ``height`` less
    ``support_band`` (m) lie over the footprint of the points ``low`` [m, 3], in cells of twice
    ``superpoint_voxel``: what hangs below a region's top over it, not beside it as foliage hangs beside its
    pot."""
    cell = 2.0 * cfg.superpoint_voxel
    below = top[top[:, 2] < height - cfg.support_band, :2]
    if len(below) < cfg.min_contacts:
        return False
    own = np.unique(np.floor(low[:, :2] / cell).astype(np.int64), axis=0)
    cells = np.floor(below / cell).astype(np.int64)
    inside = (cells[:, None, :] == own[None, :, :]).all(axis=2).any(axis=1)
    return int(inside.sum()) >= cfg.min_contacts


def _join_stored_rows(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """A region that touches a larger one and stands within its bounds (footprint within ``top_margin``,
    above its lowest point and under its highest), upright under a board of it (``_stored_upright``) and not
    in layers (``_in_layers``), joins it: a row of books standing in a bookcase that the graph never joined
    to the case is the case's, as ``_stored_bodies`` leaves such a row to the case when it is. A book stack
    lies flat or shows its layers, and stays apart. ``region`` [s] (0: none); returns the regions and how
    many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    size = np.bincount(region, g.count, n)
    point_region = region[g.label]
    by_region, start = points_by_region(point_region, n)
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts):
        r, case = (a, b) if size[a] < size[b] else (b, a)
        if remap[r] != r or remap[case] != case:
            continue
        within = np.all(lo[r, :2] >= lo[case, :2] - cfg.top_margin) and np.all(
            hi[r, :2] <= hi[case, :2] + cfg.top_margin
        )
        if not within or lo[r, 2] < lo[case, 2] or hi[r, 2] >= hi[case, 2]:
            continue
        case_points = sp.points[by_region[start[case] : start[case + 1]]]
        if _stored_upright(case_points, lo[r], hi[r], cfg) and not _in_layers(sp, point_region == r, cfg):
            remap[r] = case
            joined += 1
    while np.any(remap[remap] != remap):  # a row joined to a region that itself joined a larger one
        remap = remap[remap]
    return remap[region], joined


def _join_brackets(
    sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig, planes: list[dict[str, Any]]
) -> tuple[NDArray[np.int64], int]:
    """A slender region hanging on a wall (``_hangs``) and reaching ``bracket_min_depth`` out from it joins
    the broader region it touches whose points lie over its footprint (within ``stem_margin``) from
    ``support_band`` under its top to ``stem_gap`` over it, ``min_contacts`` of them: a wall shelf's bracket
    under the board. ``_join_stems`` misses it when the board's region already holds the other bracket,
    whose foot is then the region's lowest point. Slender: at most ``leg_width`` one way and clear of
    ``support_min_height``; broader: wider than it both ways. ``region`` [s] (0: none); returns the regions
    and how many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    width = hi[:, :2] - lo[:, :2]
    slender = (np.min(width, axis=1) <= cfg.leg_width) & (lo[:, 2] > cfg.support_min_height)
    slender[0] = False
    point_region = region[g.label]
    xy, z = sp.points[:, :2], sp.points[:, 2]
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, slender):
        for low, top in ((a, b), (b, a)):
            if not slender[low] or remap[low] != low or remap[top] != top or np.any(width[top] <= width[low]):
                continue
            centre = 0.5 * (lo[low, :2] + hi[low, :2])
            over = np.all(np.abs(xy - centre) <= 0.5 * width[low] + cfg.stem_margin, axis=1)
            over &= (point_region == top) & (z >= hi[low, 2] - cfg.support_band) & (z <= hi[low, 2] + cfg.stem_gap)
            if int(over.sum()) < cfg.min_contacts or not _hangs(sp, point_region, low, lo[low], hi[low], planes, cfg):
                continue
            if _out_from_wall(sp.points[point_region == low], planes) < cfg.bracket_min_depth:
                continue  # flat on the wall: a picture or a mirror hung under a shelf
            remap[low] = top
            joined += 1
    return remap[region], joined


def _hangs(
    sp: ScanPoints,
    point_region: NDArray[np.int64],
    r: int,
    lo: NDArray,
    hi: NDArray,
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
) -> bool:
    """Whether region r (bounds ``lo``, ``hi`` [3], m) hangs on a wall: clear of the floor (its lowest point
    above ``support_min_height``), fixed to a wall (``min_contacts`` of its points within ``structure_band``
    of a wall plane, most of them off it) and with nothing of another region under it (fewer than
    ``min_contacts`` points within its footprint from 2 ``support_band`` under its lowest point up to it). A
    wall shelf's bracket under the shelf's board hangs from it; a book stack under another stands on its
    shelf, and a lamp's shade stands on its stem."""
    mine = point_region == r
    if lo[2] <= cfg.support_min_height or (sp.wall[mine] > 0).mean() >= 0.5:
        return False
    walls = [q for q in planes if q["kind"] == "wall"]
    own = sp.points[mine]
    near = [np.abs(own @ np.asarray(q["normal"]) + q["offset"]) < cfg.structure_band for q in walls]
    if not walls or int(np.any(near, axis=0).sum()) < cfg.min_contacts:
        return False
    p = sp.points
    under = np.all((p[:, :2] >= lo[:2]) & (p[:, :2] <= hi[:2]), axis=1)
    under &= (p[:, 2] >= lo[2] - 2 * cfg.support_band) & (p[:, 2] < lo[2]) & (point_region > 0) & ~mine
    return int(under.sum()) < cfg.min_contacts


def _bedding_top(tops: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a body with bounds ``lo``, ``hi`` [3] (m) lies on a mattress: the upward-facing points ``tops``
    [k, 3] of the region it touches, from ``support_band`` below its lowest height to ``bedding_duvet`` above
    it, form a level between ``bedding_min_height`` and ``bedding_max_height`` above the floor, at least
    ``bedding_min_length`` by ``bedding_min_width`` across, that reaches beyond the body both ways and lies
    under its footprint (``min_contacts`` points)."""
    level = tops[(tops[:, 2] >= lo[2] - cfg.support_band) & (tops[:, 2] <= lo[2] + cfg.bedding_duvet)]
    if len(level) < cfg.top_min_points:
        return False
    height = float(np.median(level[:, 2]))
    if not cfg.bedding_min_height <= height <= cfg.bedding_max_height:
        return False
    span = np.ptp(level[:, :2], axis=0)
    if span.max() < cfg.bedding_min_length or span.min() < cfg.bedding_min_width:
        return False
    if np.any(hi[:2] - lo[:2] >= span):
        return False  # as broad as the top one way: the mattress itself on its frame, not bedding on it
    grown_lo, grown_hi = lo[:2] - cfg.support_band, hi[:2] + cfg.support_band
    under = np.all((level[:, :2] >= grown_lo) & (level[:, :2] <= grown_hi), axis=1)
    return int(under.sum()) >= cfg.min_contacts


def _join_bedding(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """A low flat region (no taller than ``bedding_flatness`` of its smaller horizontal extent) lying on a
    mattress of a region it touches (``_bedding_top``) joins that region: a bed's pillows, parted from the
    mattress by the support cut, by the split at a top or by their colour, are part of the bed. A monitor or
    a lamp stands taller than it is deep; a book stack lies on a top too small or too high for a mattress; a
    sofa's seat is shallower than a mattress and its back cushions stand upright. ``region`` [s] (0: none);
    returns the regions and how many joined."""
    g = sp.graph
    n = int(region.max(initial=0)) + 1
    lo, hi = _region_bounds(g, region, n)
    flat = (hi[:, 2] - lo[:, 2]) <= cfg.bedding_flatness * (hi[:, :2] - lo[:, :2]).min(axis=1)
    point_region = region[g.label]
    up = _facing_up(sp.normals)
    remap = np.arange(n)
    joined = 0
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, among=flat):
        for body, bed in ((a, b), (b, a)):
            if not flat[body] or remap[body] != body or remap[bed] != bed:
                continue
            if _bedding_top(sp.points[up & (point_region == bed)], lo[body], hi[body], cfg):
                remap[body] = bed
                joined += 1
    for _ in range(3):  # a pillow joins a region that may itself have joined another: follow the chain
        remap = remap[remap]
    return remap[region], joined


def _rests_on(
    tops: NDArray, lo: NDArray, hi: NDArray, big_lo: NDArray, big_hi: NDArray, min_height: float, cfg: SegmentConfig
) -> bool:
    """Whether a region with bounds ``lo``, ``hi`` [3] (m) stands on an upward-facing surface of a larger one
    (``tops`` [k, 3]: its points whose normal is within 15 degrees of up; bounds ``big_lo``, ``big_hi``):
    some of those points lie under its footprint at its lowest height (within ``support_band``), the top is
    higher than ``min_height`` (m), the region is at least ``body_min_thickness`` thick every way (no board
    or panel), and it is narrower than the larger region both ways (a mattress spans its bed's frame and stays
    with it) or one way only with the top reaching ``top_margin`` beyond it on both sides the other way at
    its lowest height (``_sides_beyond``: a book stack as deep as its shelf, clear of the shelf's ends)."""
    if min(hi - lo) < cfg.body_min_thickness or lo[2] < min_height - cfg.support_band:
        return False  # a board or a panel of the larger one, not a body on it
    spans = hi[:2] - lo[:2] >= cfg.support_span_fraction * (big_hi[:2] - big_lo[:2])
    if spans.all():
        return False
    level = np.abs(tops[:, 2] - lo[2]) <= cfg.support_band
    if spans.any():  # as deep as its shelf: the shelf reaches beyond it on both sides the other way
        across = _sides_beyond(lo, hi, tops[level, :2], cfg)
        if not (across[2:] if spans[0] else across[:2]).all():
            return False
    under = np.all((tops[:, :2] >= lo[:2] - cfg.support_band) & (tops[:, :2] <= hi[:2] + cfg.support_band), axis=1)
    return int((under & level).sum()) >= cfg.min_contacts


def _under_board(case: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig, reach: float = np.inf) -> bool:
    """Whether ``min_contacts`` of a case's points ``case`` [k, 3] lie over the footprint of what stands in
    it (bounds ``lo``, ``hi`` [3], m), higher than its top by at most ``reach`` (m): a shelf board over a
    book stack."""
    over = np.all((case[:, :2] >= lo[:2]) & (case[:, :2] <= hi[:2]), axis=1)
    over &= (case[:, 2] > hi[2]) & (case[:, 2] <= hi[2] + reach)
    return int(over.sum()) >= cfg.min_contacts


def _board_share(case: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> float:
    """The share of the footprint of what stands in a case (bounds ``lo``, ``hi`` [3], m), in cells of twice
    ``superpoint_voxel``, that has a point of the case ``case`` [k, 3] over it, higher than its top by at
    most ``stored_board_reach`` (m): 1 under a shelf board."""
    cell = 2.0 * cfg.superpoint_voxel
    shape = np.maximum(np.ceil((hi[:2] - lo[:2]) / cell).astype(np.int64), 1)
    over = np.all((case[:, :2] >= lo[:2]) & (case[:, :2] <= hi[:2]), axis=1)
    over &= (case[:, 2] > hi[2]) & (case[:, 2] <= hi[2] + cfg.stored_board_reach)
    ij = np.minimum(((case[over, :2] - lo[:2]) / cell).astype(np.int64), shape - 1)
    return len(np.unique(ij[:, 0] * shape[1] + ij[:, 1])) / float(np.prod(shape))


def _in_layers(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> bool:
    """Whether a body's points ``body`` [n] change colour across horizontal seams: ``layer_share`` or more of
    the point edges within it that step ``layer_colour_step`` in colour run more up than across, over
    ``layer_min_edges`` of them (books lying flat; the seams of books standing upright are vertical)."""
    seams, rising = _seams(sp, body, cfg)
    return seams >= cfg.layer_min_edges and rising >= cfg.layer_share


def _case_books(sp: ScanPoints, body: NDArray[np.bool_], tall: float, narrow: float, cfg: SegmentConfig) -> bool:
    """Whether a body parted from its case by colour alone, ``tall`` over its shelf and ``narrow`` across its
    narrower side (m), is the case's own: its colour seams in rows (``_in_rows``) and ``row_min_height``
    tall (books standing upright), or taller than ``narrow`` and not in layers (``_in_layers``: a tall
    stack lies in layers). ``body`` [n]: its points."""
    seams, rising = _seams(sp, body, cfg)  # once for both tests
    counted = seams >= cfg.layer_min_edges
    in_rows, in_layers = counted and rising < cfg.layer_share, counted and rising >= cfg.layer_share
    return (tall >= cfg.row_min_height and in_rows) or (tall >= narrow and not in_layers)


def _in_rows(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> bool:
    """Whether a body's points ``body`` [n] change colour across vertical seams: over ``layer_min_edges`` point
    edges within it step ``layer_colour_step`` in colour and fewer than ``layer_share`` of them run more up
    than across (books standing upright in a row; a stack of two books shows too few seams to tell)."""
    seams, rising = _seams(sp, body, cfg)
    return seams >= cfg.layer_min_edges and rising < cfg.layer_share


def _seams(sp: ScanPoints, body: NDArray[np.bool_], cfg: SegmentConfig) -> tuple[int, float]:
    """How many point edges within a body's points ``body`` [n] step ``layer_colour_step`` in colour, and
    the share of them that run more up than across (0 when none)."""
    i0, i1 = sp.edges[:, 0], sp.edges[:, 1]
    seam = body[i0] & body[i1] & (sp.colour_step >= cfg.layer_colour_step)
    if not seam.any():
        return 0, 0.0
    d = sp.points[i1[seam]] - sp.points[i0[seam]]
    return int(seam.sum()), float((np.abs(d[:, 2]) > np.linalg.norm(d[:, :2], axis=1)).mean())


def _stored_upright(big: NDArray, lo: NDArray, hi: NDArray, cfg: SegmentConfig) -> bool:
    """Whether a region with bounds ``lo``, ``hi`` [3] (m) resting on a shelf of a larger one (its points
    ``big`` [k, 3]) is stored in it: taller than its smaller horizontal extent (books standing upright)
    and under a board of the larger one (``min_contacts`` of its points over the footprint, at most
    ``stored_cover_gap`` above the top). A book stack lies flat; a monitor or a lamp has no board over it."""
    if hi[2] - lo[2] < min(hi[:2] - lo[:2]):
        return False
    return _under_board(big, lo, hi, cfg, cfg.stored_cover_gap)


def _attach_legs(sp: ScanPoints, region: NDArray[np.int64], cfg: SegmentConfig) -> tuple[NDArray[np.int64], int]:
    """Slender upright regions (narrower than ``leg_max_width`` one way or both, twice as tall as that) whose
    upper end lies just under a broader region join it: the legs and side panels of a table or a desk, cut
    off at the crease under its top, or parted from it by a gap the fusion left. The broader region has
    ``min_contacts`` points or more above the upright's footprint (grown by ``support_band``) between
    ``support_band`` below its upper end and three times that above, and its bounds contain that footprint;
    with no surface there, the smallest region whose bounds hold the upright's upper end and footprint and
    begin at most three ``support_band`` below that end (a floor lamp's pole reaching into its open shade).
    Returns the regions and how many joined."""
    g = sp.graph
    region = region.copy()
    n = int(region.max()) + 1
    point_region = region[g.label]
    lo, hi = _region_bounds(g, region, n)
    span = hi - lo
    narrow = span[:, :2].min(axis=1)
    slender = (narrow <= cfg.leg_max_width) & (span[:, 2] >= 2 * narrow) & (np.arange(n) > 0)
    slender &= lo[:, 2] <= cfg.support_min_height  # it stands on the floor, or nearly
    joined = 0
    remap = np.arange(n)
    band = cfg.support_band
    for r in np.flatnonzero(slender).tolist():
        near = np.all((sp.points[:, :2] >= lo[r, :2] - band) & (sp.points[:, :2] <= hi[r, :2] + band), axis=1)
        near &= (sp.points[:, 2] >= hi[r, 2] - band) & (sp.points[:, 2] <= hi[r, 2] + 3 * band)
        owners = point_region[near]
        owners = owners[(owners > 0) & (owners != r)]
        top = int(np.bincount(owners).argmax()) if len(owners) else 0
        if len(owners) < cfg.min_contacts or np.bincount(owners)[top] < cfg.min_contacts or slender[top]:
            # no surface just above it: its upper end may reach into a hollow region hanging over it (a
            # floor lamp's pole ends inside its open shade, whose surface lies beyond the pole's footprint)
            top = _hollow_over(r, lo, hi, slender, band)
            if top == 0:
                continue
        inside = np.all(lo[top, :2] - band <= lo[r, :2]) and np.all(hi[r, :2] <= hi[top, :2] + band)
        if inside and hi[top, 2] > hi[r, 2] + band:
            remap[r] = top
            joined += 1
    # a leg joins a top that may itself have joined another: follow the chain
    for _ in range(3):
        remap = remap[remap]
    return remap[region], joined


def _attach_backs(
    sp: ScanPoints, region: NDArray[np.int64], planes: list[dict[str, Any]], cfg: SegmentConfig
) -> tuple[NDArray[np.int64], int]:
    """Regions standing near the floor and lying wholly within ``back_depth`` in front of one wall, with a
    broader region's surface over them (``min_contacts`` points or more above their footprint, grown by
    ``support_band``, from ``support_band`` under their upper end to ``back_reach`` over it), join the region
    that holds at least ``stem_overlap`` of their stretch along the wall and rises past their upper end: a
    desk's back legs and back rail, fused with the wall they stand against, whose upper part the fusion gave
    to the wall (so that the leg ends short of the top) and whose smear along the wall reaches past the
    desk's end. Whatever stands against the wall under a desk deeper than ``back_depth`` (a bin, a drawer
    unit) stays apart.
    A region within ``back_depth`` of a wall reaching from under the top of a region it touches
    (``min_contacts`` graph contacts) to over it, that region holding that share of its stretch and it
    spanning ``support_span_fraction`` of that region's, joins it (a mirror standing behind a desk is
    narrower than the desk): a bed's headboard, its lower part hidden behind the bed, upright as a monitor
    on a desk and parted from the bedding by colour and the crease where the mattress meets it. Returns the
    regions and how many joined."""
    g = sp.graph
    walls = [(np.asarray(q["normal"], float), float(q["offset"])) for q in planes if q["kind"] == "wall"]
    n = int(region.max(initial=0)) + 1
    if not walls or n <= 1:
        return region, 0
    point_region = region[g.label]
    lo, hi = _region_bounds(g, region, n)
    by_region, start = points_by_region(point_region, n)
    # the depth of each region in front of each wall: the larger of its 95th-percentile distance either side
    depth = np.full(n, np.inf)
    wall_of = np.zeros(n, np.int64)
    count = np.diff(start)
    k95 = start[:-1] + np.maximum(np.ceil(0.95 * count).astype(np.int64) - 1, 0)
    has = count > 0
    for i, (normal, offset) in enumerate(walls):
        d = np.abs(sp.points @ normal + offset)
        srt = np.argsort(point_region * 1.0 + np.minimum(d, 0.999), kind="stable")  # by region, then distance
        nearer = has & (d[srt[k95]] < depth)
        depth[nearer] = d[srt[k95[nearer]]]
        wall_of[nearer] = i
    against = (depth <= cfg.back_depth) & (np.arange(n) > 0)
    back = against & (lo[:, 2] <= cfg.support_min_height)

    def along_share(r: int, other: int, wall: int) -> float:
        """Share of region r's stretch along a wall that lies within the other's (grown by ``support_band``)."""
        normal = walls[wall][0]
        horiz = np.array([-normal[1], normal[0], 0.0])
        a = sp.points[by_region[start[r] : start[r + 1]]] @ horiz
        b = sp.points[by_region[start[other] : start[other + 1]]] @ horiz
        cover = min(a.max(), b.max() + cfg.support_band) - max(a.min(), b.min() - cfg.support_band)
        return max(cover, 0.0) / max(float(np.ptp(a)), 1e-3)

    remap = np.arange(n)
    joined = 0
    band = cfg.support_band
    for r in np.flatnonzero(back).tolist():
        over = np.all((sp.points[:, :2] >= lo[r, :2] - band) & (sp.points[:, :2] <= hi[r, :2] + band), axis=1)
        over &= (sp.points[:, 2] >= hi[r, 2] - band) & (sp.points[:, 2] <= hi[r, 2] + cfg.back_reach)
        owners = point_region[over]
        owners = owners[(owners > 0) & (owners != r) & ~back[owners]]
        if len(owners) < cfg.min_contacts:
            continue
        top = int(np.bincount(owners).argmax())
        if np.bincount(owners)[top] < cfg.min_contacts or hi[top, 2] <= hi[r, 2]:
            continue
        if along_share(r, top, wall_of[r]) >= cfg.stem_overlap:
            remap[r] = top
            joined += 1
    # a region against the wall reaching from below the top of a region it touches to over it, that region
    # holding its stretch: a bed's headboard (its lower part hidden behind the bed)
    for a, b in _touching_regions(g, region, n, cfg.min_contacts, among=against):
        for r, nb in ((a, b), (b, a)):
            if not against[r] or against[nb] or remap[r] != r:
                continue
            if lo[r, 2] >= hi[nb, 2] - band or hi[r, 2] <= hi[nb, 2] + band:
                continue
            # and spans it (a mirror standing behind a desk, narrower than the desk, is no part of it)
            w = wall_of[r]
            if along_share(r, nb, w) >= cfg.stem_overlap and along_share(nb, r, w) >= cfg.support_span_fraction:
                remap[r] = nb
                joined += 1
    for _ in range(3):
        remap = remap[remap]
    return remap[region], joined


def _hollow_over(r: int, lo: NDArray, hi: NDArray, slender: NDArray[np.bool_], band: float) -> int:
    """The region (0: none) whose bounds ``lo``, ``hi`` [n, 3] (m) hold region r's upper end and footprint and
    begin within three ``band`` below that end: what r reaches up into. The smallest such region wins."""
    cand = (lo[:, :2] - band <= lo[r, :2]).all(axis=1) & (hi[r, :2] <= hi[:, :2] + band).all(axis=1)
    cand &= (lo[:, 2] >= hi[r, 2] - 3 * band) & (lo[:, 2] <= hi[r, 2] + band) & (hi[:, 2] > hi[r, 2] + band)
    cand &= ~slender & (np.arange(len(lo)) > 0)
    cand[r] = False
    if not cand.any():
        return 0
    volume = np.prod(np.where(cand[:, None], hi - lo, np.inf), axis=1)
    return int(np.argmin(volume))


def _absorb_small(g: SuperpointGraph, region: NDArray[np.int64], cfg: SegmentConfig) -> NDArray[np.int64]:
    """Regions with fewer than ``min_segment_points`` points, and thin upright parts (legs, posts: narrower
    than ``leg_width`` and twice as tall as wide), join the touching region they share the most contacts
    with: the leg cut off at the crease under a table's top goes back to the table."""
    region = region.copy()
    for _ in range(3):
        n = int(region.max()) + 1
        pts = np.bincount(region, g.count, n)
        lo, hi = _region_bounds(g, region, n)
        width = (hi[:, :2] - lo[:, :2]).max(axis=1)
        thin = (width <= cfg.leg_width) & (hi[:, 2] - lo[:, 2] >= 2 * width)
        ra, rb = region[g.pairs[:, 0]], region[g.pairs[:, 1]]
        ok = (ra > 0) & (rb > 0) & (ra != rb)
        if not ok.any():
            break
        src = np.r_[ra[ok], rb[ok]]
        dst = np.r_[rb[ok], ra[ok]]
        w = np.r_[g.contacts[ok], g.contacts[ok]]
        small = (pts[src] < cfg.min_segment_points) | (thin[src] & ~thin[dst])
        if not small.any():
            break
        src, dst, w = src[small], dst[small], w[small]
        order = np.lexsort((-w, src))
        src, dst = src[order], dst[order]
        first = np.r_[True, src[1:] != src[:-1]]
        remap = np.arange(len(pts))
        for s_, d_ in zip(src[first].tolist(), dst[first].tolist(), strict=True):
            if remap[d_] != s_:  # do not let two small regions swap into each other
                remap[s_] = remap[d_]
        region = remap[region]
    return region


def _structure_distance(p: NDArray, planes: list[dict[str, Any]]) -> NDArray[np.float64]:
    """Distance [k] of points [k, 3] to the nearest structure plane: the floor (z = 0), a wall, the ceiling (m)."""
    dist = np.abs(p[:, 2])
    for plane in planes:
        if plane["kind"] == "wall":
            dist = np.minimum(dist, np.abs(p @ np.asarray(plane["normal"]) + plane["offset"]))
        elif plane["kind"] == "ceiling":
            dist = np.minimum(dist, np.abs(p[:, 2] - plane["height"]))
    return dist


def _mostly_structure(dist: NDArray, cfg: SegmentConfig) -> bool:
    """Whether ``structure_sliver_fraction`` of a region's points, ``dist`` [k] (m) from the nearest structure
    plane (``_structure_distance``), lie within ``structure_band`` of it: the first test of a sliver."""
    return bool((dist < cfg.structure_band).mean() >= cfg.structure_sliver_fraction)


def _is_wall_piece(p: NDArray, cfg: SegmentConfig) -> bool:
    """A region [k, 3] that is one upright sheet (under ``sliver_thickness`` thick across its flattest
    direction, which is horizontal) and at least ``wall_piece_height`` tall: a stretch of wall the plane
    search missed, or a door; no piece of furniture is a sheet that tall."""
    if np.ptp(p[:, 2]) < cfg.wall_piece_height or len(p) < 10:
        return False
    centred = p - p.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    if abs(normal[2]) > np.sin(np.radians(cfg.vertical_tolerance_deg)):
        return False
    across = centred @ normal
    return bool(np.subtract(*np.percentile(across, [95, 5])) < cfg.sliver_thickness)


def _nearest_wall(p: NDArray, planes: list[dict[str, Any]]) -> int:
    """Id of the wall nearest (by median distance) to the points [k, 3]; 0 when there is no wall."""
    walls = [q for q in planes if q["kind"] == "wall"]
    if not walls:
        return 0
    gaps = [float(np.median(np.abs(p @ np.asarray(q["normal"]) + q["offset"]))) for q in walls]
    return int(walls[int(np.argmin(gaps))]["id"])


def _out_from_wall(p: NDArray, planes: list[dict[str, Any]]) -> float:
    """How far the points [k, 3] reach out from their nearest wall (``_nearest_wall``): the extent (m) of their
    distances to its plane; 0 when there is no wall."""
    wall = _nearest_wall(p, planes)
    if wall == 0 or len(p) == 0:
        return 0.0
    q = next(q for q in planes if q["id"] == wall)
    return float(np.ptp(p @ np.asarray(q["normal"])))


def _in_shadow(colours: NDArray, wall_colour: NDArray | None, cfg: SegmentConfig) -> bool:
    """Whether a region's colours [k, 3] (RGB in [0, 1]) are, on average, its wall's colour [3] darkened
    (``_shaded``): a sharp outline of such a region is the edge of a shadow, not of a picture."""
    if wall_colour is None:
        return False
    return bool(_shaded(colours.mean(axis=0)[None], wall_colour, cfg.flush_shadow_tint)[0])


def _faces_wall(p: NDArray, normals: NDArray, planes: list[dict[str, Any]], cfg: SegmentConfig) -> bool:
    """Whether most points [k, 3] of a region lie with their normals [k, 3] within ``plane_normal_deg`` of
    the normal of the wall nearest to them (by median distance)."""
    wall = _nearest_wall(p, planes)
    if wall == 0:
        return False
    n = np.asarray(next(q["normal"] for q in planes if q["kind"] == "wall" and q["id"] == wall))
    return bool((np.abs(normals @ n) > np.cos(np.radians(cfg.plane_normal_deg))).mean() >= 0.5)


def _rim_step(g: SuperpointGraph, rim: NDArray[np.bool_]) -> float:
    """Mean colour step (RGB distance / sqrt 3) over the graph edges of the contacts ``rim`` [p]."""
    return float((g.step[rim] * g.contacts[rim]).sum() / max(int(g.contacts[rim].sum()), 1))


def _filter_regions(
    sp: ScanPoints,
    region: NDArray[np.int64],
    which_wall: NDArray[np.int64],
    planes: list[dict[str, Any]],
    cfg: SegmentConfig,
    flush_by_masks: bool = False,
) -> tuple[NDArray[np.int64], dict[str, int]]:
    """Regions renumbered 1..k after dropping the too small, the too large (leftovers of the room), slivers
    of the structure (a region within ``structure_band`` of the floor, walls and ceiling and thinner than
    ``sliver_thickness`` across them: the rounded corner where a wall meets the ceiling) and wall patches
    that are not flush objects (touching the floor or ceiling, as a door does, or of the wall's colour, or
    outlined only as a shadow is)."""
    g = sp.graph
    point_region = region[g.label]
    out = np.zeros_like(region)
    counts = {"too_small": 0, "too_large": 0, "joined_structure": 0, "flush_objects": 0, "wall_patches": 0}
    ceiling = [float(p["height"]) for p in planes if p["kind"] == "ceiling"]
    top = ceiling[0] if ceiling else np.inf
    normals = {int(p["id"]): (np.asarray(p["normal"]), float(p["offset"])) for p in planes if p["kind"] == "wall"}
    paint = wall_colours(sp)
    nxt = 1
    order, bounds = points_by_region(point_region, int(region.max()) + 1)
    for r in range(1, int(region.max()) + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) == 0:
            continue
        p = sp.points[idx]
        ext = float(np.ptp(p, axis=0).max())
        if len(idx) < cfg.min_segment_points or ext < cfg.min_segment_extent:
            counts["too_small"] += 1
            continue
        if ext > cfg.max_segment_extent:
            counts["too_large"] += 1
            continue
        walls, n_on = np.unique(sp.wall[idx], return_counts=True)
        wall = int(walls[np.argmax(n_on)])
        hangs = p[:, 2].min() >= cfg.flush_min_height and p[:, 2].max() <= top - cfg.flush_ceiling_gap
        # the colour step right across its outline, against the wall around it: a picture's edge is
        # sharp, a shading gradient on the paint is not
        inside = region[g.pairs[:, 0]] == r
        outside = region[g.pairs[:, 1]] == r
        rim_wall = np.where(inside, which_wall[g.pairs[:, 1]], which_wall[g.pairs[:, 0]])
        if wall > 0 and n_on.max() >= 0.5 * len(idx):
            n, d = normals[wall]
            proud = float(np.median(p @ n + d))
            edge = _rim_step(g, (inside ^ outside) & (rim_wall == wall))
            # with masks the region is already a consensus of views: hanging clear is enough
            outline = edge >= cfg.flush_edge_step and not _in_shadow(sp.colours[idx], paint.get(wall), cfg)
            apart = flush_by_masks or outline or proud >= cfg.flush_offset
            if hangs and ext <= cfg.flush_max_extent and apart:
                counts["flush_objects"] += 1
                out[region == r] = nxt
                nxt += 1
            else:
                counts["wall_patches"] += 1
            continue
        if _is_wall_piece(p, cfg):
            counts["joined_structure"] += 1
            continue
        dist = _structure_distance(p, planes)
        sliver = _mostly_structure(dist, cfg)
        # thinner than ``sliver_thickness`` across the plane, or as tall as a wall (a stretch of wall whose
        # fused surface wanders a few centimetres about the plane: no furniture lies along a wall that tall)
        sliver &= bool(np.percentile(dist, 95) < cfg.sliver_thickness) or bool(np.ptp(p[:, 2]) >= cfg.wall_piece_height)
        if sliver and hangs:
            # a thin region hanging on a wall off its plane (a wall clock, a mirror's frame): an object when
            # the masks see it apart, when its outline steps in colour, or when it stands proud of the wall
            # and faces the room as the wall does (a stretch of the wall whose fused normals stray off the
            # plane's, and so stayed off it, lies in it and faces every way)
            edge = _rim_step(g, (inside ^ outside) & (rim_wall > 0))
            near = paint.get(_nearest_wall(p, planes))
            outline = edge >= cfg.flush_edge_step and not _in_shadow(sp.colours[idx], near, cfg)
            proud = float(np.median(dist)) >= cfg.flush_offset and _faces_wall(p, sp.normals[idx], planes, cfg)
            if flush_by_masks or outline or proud:
                sliver = False
        if sliver:
            counts["joined_structure"] += 1
            continue
        out[region == r] = nxt
        nxt += 1
    counts["kept"] = nxt - 1
    return out, counts


def _finish(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    verts: NDArray,
    faces: NDArray[np.int64],
    struct: NDArray[np.int64],
    planes: list[dict[str, Any]],
    sp: ScanPoints,
    region: NDArray[np.int64],
    cfg: SegmentConfig,
    segmenter: str,
    stats: dict[str, Any],
    clip_model: str | None,
    clip_model_name: str,
    vocabulary: tuple[str, ...],
) -> SegmentResult:
    """Vertex labels from the structure and the object regions, rendered into every frame; labels; report."""
    T, H, W = depth.shape
    n_struct = max(int(p["id"]) for p in planes)
    vregion = np.zeros(len(verts), np.int64)
    mapped = sp.vertex_point >= 0
    vregion[mapped] = region[sp.graph.label[sp.vertex_point[mapped]]]
    vlabel = np.where(vregion > 0, vregion + n_struct, struct)
    # a face takes the label two or three of its vertices share, else none
    fl = vlabel[faces]
    face_label = np.where(
        (fl[:, 0] == fl[:, 1]) | (fl[:, 0] == fl[:, 2]), fl[:, 0], np.where(fl[:, 1] == fl[:, 2], fl[:, 1], 0)
    )
    caster = RayCaster(labelled_meshes(verts, faces, face_label))
    masks, rstats = render_masks(
        caster, K, world_from_cam, W, H, depth, cfg.depth_abs_tolerance, cfg.depth_rel_tolerance
    )
    counts = np.bincount((masks.reshape(T, -1).astype(np.int64) + np.arange(T)[:, None] * (int(masks.max()) + 1)).ravel(),
                         minlength=T * (int(masks.max()) + 1)).reshape(T, -1)  # fmt: skip
    small = (counts > 0) & (counts < cfg.min_mask_pixels)
    small[:, 0] = False
    if small.any():
        masks[np.take_along_axis(small, masks.reshape(T, -1).astype(np.int64), axis=1).reshape(masks.shape)] = 0
    present = {int(i) for i in np.flatnonzero(np.bincount(masks.ravel())) if i > 0}
    kinds = {p["id"]: p["kind"] for p in planes}
    labels: dict[int, tuple[str, bool]] = {}
    for i in sorted(present):
        labels[i] = (kinds[i], True) if i in kinds else ("object", False)
    objects = [i for i in labels if not labels[i][1]]
    if not objects:
        raise SegmentError(
            f"empty scene after segmentation: {stats.get('superpoints', 0)} superpoints, none kept in an object "
            f"({stats.get('too_small', 0)} regions smaller than {cfg.min_segment_extent} m or {cfg.min_segment_points} "
            f"points, {stats.get('too_large', 0)} larger than {cfg.max_segment_extent} m); the recording may not show "
            "objects clear of the floor and walls"
        )
    label_report: dict[str, Any] = {"labeller": "none (every segment is 'object')"}
    if clip_model:
        names, label_report = zero_shot_labels(
            rgb, masks, objects, clip_model, clip_model_name, vocabulary, cfg.clip_views
        )
        for i, name in names.items():
            labels[i] = (name, False)
        segmenter += "+clip"
    report = {
        "segmenter": segmenter,
        "mesh": {"vertices": int(len(verts)), "faces": int(len(faces)), "tsdf_voxel": cfg.tsdf_voxel},
        "planes": planes,
        "regions": stats,
        "render": rstats,
        "objects": len(objects),
        "structural": len(labels) - len(objects),
        "labels": label_report,
        "config": cfg.model_dump(mode="json"),
    }
    return SegmentResult(masks, labels, segmenter, report, verts, faces, face_label)


def fuse_scan(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    cfg: SegmentConfig,
    fh_k: float | None = None,
) -> tuple[NDArray, NDArray[np.int64], NDArray[np.int64], list[dict[str, Any]], ScanPoints, dict[str, float]]:
    """Steps 1-3 shared by both front ends: mesh vertices [v, 3], faces [f, 3], structure label per vertex,
    the planes, the superpoints and the seconds each step took."""
    seconds: dict[str, float] = {}
    # Open3D on one thread, its engine seeded: on several, the TSDF's surface and the RANSAC planes differ
    # from run to run (a wall's offset by 0.5 mm, a few superpoints more or less, objects matched or not)
    with seeded_open3d_rng(cfg.seed):
        t = time.perf_counter()
        verts, faces, normals, colours = tsdf_mesh(rgb, depth, K, world_from_cam, cfg)
        if len(faces) == 0:
            raise SegmentError("TSDF fusion produced no surface (no valid depth in range; check --depth-scale)")
        seconds["tsdf"] = time.perf_counter() - t
        t = time.perf_counter()
        cams = np.asarray(world_from_cam)[:, :3, 3]
        struct, planes = _structure(verts, normals, cams, cfg)
        seconds["structure"] = time.perf_counter() - t
        t = time.perf_counter()
        sp = scan_points(verts, normals, colours, struct, planes, cfg, fh_k)
        seconds["superpoints"] = time.perf_counter() - t
    return verts, faces, struct, planes, sp, seconds


def segment_geometric(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.float32],
    K: NDArray,
    world_from_cam: NDArray,
    config: SegmentConfig | None = None,
    clip_model: str | None = None,
    clip_model_name: str = "ViT-B-32",
    vocabulary: tuple[str, ...] = ("object",),
) -> SegmentResult:
    """Label-free instances of an aligned RGB-D capture (world z up, floor at z = 0).

    rgb [T, H, W, 3] uint8, depth [T, H, W] float32 metres (0 invalid), K [T, 3, 3], world_from_cam
    [T, 4, 4] (OpenCV axes). clip_model: a local open_clip checkpoint to label segments zero-shot.
    """
    cfg = config or SegmentConfig()
    verts, faces, struct, planes, sp, seconds = fuse_scan(rgb, depth, K, world_from_cam, cfg)
    t = time.perf_counter()
    sp, region, _, stats = merge_superpoints(sp, planes, cfg)
    seconds["merge"] = time.perf_counter() - t
    t = time.perf_counter()
    result = _finish(rgb, depth, K, world_from_cam, verts, faces, struct, planes, sp, region, cfg, "geometric",
                     stats, clip_model, clip_model_name, vocabulary)  # fmt: skip
    seconds["render_and_labels"] = time.perf_counter() - t
    result.report["seconds"] = {k: round(v, 2) for k, v in seconds.items()}
    return result
