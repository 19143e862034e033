"""The label-free segmenter's settings (``SegmentConfig``): lengths in metres, angles in degrees."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


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
    fill_radius: float = 0.05
    """A pixel the ray cast leaves unlabelled (a hole in the fused mesh, a ray through a thin panel to the wall
    behind it) takes the label of the mesh vertex nearest its measured point when that lies at most this
    far (m); 0: no filling. (Traced on a desk's unlabelled pixels, cluttered 304: their points lay a median
    2.1 cm from the nearest vertex of its segment, 90 % within 5.2 cm.)"""
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
    wall_side_gap: float = 0.08
    """... where a side of a body's foot within this distance (m) of a wall counts as one the top reaches
    beyond, when the top is seen beyond the side across from it (a monitor or a book stack at the back of a
    desk against the wall, the desk's top seen in front of it) ..."""
    wall_side_max_length: float = 1.0
    """... and the side is at most this long (m): what stands on a top along a wall is a monitor, a lamp, a
    stack of books; a longer body there is the piece's own (a bed's pillows along its headboard)."""
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
    stacked_max_width: float = 0.45
    """A region at most this wide either way (m), on the floor or over it (a book stack is 15-28 cm; with the
    edge of the shelf or table it rests on, up to 40 cm), and at least ``min_segment_extent`` both ways ..."""
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
