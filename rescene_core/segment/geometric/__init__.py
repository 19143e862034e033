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
   A compact body standing on a horizontal top of its own region (the highest top first: chairs pushed in at
   a table part from it before their seats could carry it), the top reaching beyond its foot on three
   sides or on both sides one way (a wall behind it counting as one), is split off at the top's plane (a
   monitor whose base plate rises a few centimetres), and searched in turn for bodies on its own tops (a
   bookcase's upper part split off at a nightstand beside it); so is a body stored on a shelf of a case, parted
   from the case's back and sides at its creases and where the colour leaves the case's own, with a board
   of the case over it (a book stack against a bookcase's back panel, or behind the front edge of a shelf at
   the cameras' height, the only part of the shelf seen). A small region resting on something
   that narrows sharply at some height is two bodies, split there (a book stack on a stack).
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
5. The labelled mesh is rendered into each camera with a depth test (``rescene_core.segment.project``), and a
   pixel the cast leaves unlabelled takes the label of the mesh vertex nearest its measured point within
   ``fill_radius`` (a hole in the mesh where a thin panel was seen from both sides).

``--segment masks`` (``rescene_core.segment.masks``) replaces step 4 by view consensus of per-frame 2D
masks. Every segment is labelled ``object`` unless an open_clip checkpoint is given: then the best views of
each segment are classified zero-shot over a vocabulary (``rescene_core.segment.labels``). The result says
which segmenter ran (``geometric``, ``masks``, with ``+clip`` when labelled).

The modules of this package, in the order the steps use them:

- ``config``: ``SegmentConfig``, every threshold with its unit.
- ``fusion``: step 1 and the shared steps 1-3 (``fuse_scan``).
- ``structure``: step 2, the floor, ceiling and wall planes and distances to them.
- ``points``: step 3's superpoints (``ScanPoints``) and the bookkeeping of regions over them.
- ``merge``: step 4, ``merge_superpoints``, which runs the rules of the modules below in order.
- ``colour``: a wall's paint and shadow, and what is left of a colour after a reference colour.
- ``support``: tops, boards and footprints: which body stands on or under what.
- ``walls``: wall superpoints, regions hanging on a wall, what a stretch of wall gives back.
- ``cases``: bodies stored in cases (book stacks) and the rows of books that stay with them.
- ``tops``: bodies standing on a top of their own region, split off at the top's plane.
- ``stacks``: a stack on a stack, cut where it narrows.
- ``joins``: stems, pillows, legs, backs and small pieces joining the region they belong to.
- ``filter``: which regions are objects (and which are flush objects on a wall).
- ``result``: step 5, the labelled mesh rendered into every frame, the labels and the report.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from rescene_core.segment.geometric.config import SegmentConfig
from rescene_core.segment.geometric.fusion import fuse_scan, tsdf_mesh
from rescene_core.segment.geometric.merge import merge_superpoints
from rescene_core.segment.geometric.points import ScanPoints, points_by_region, regroup, scan_points
from rescene_core.segment.geometric.result import SegmentResult, _finish
from rescene_core.segment.geometric.walls import wall_superpoints


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


__all__ = [
    "ScanPoints",
    "SegmentConfig",
    "SegmentResult",
    "fuse_scan",
    "merge_superpoints",
    "points_by_region",
    "regroup",
    "scan_points",
    "segment_geometric",
    "tsdf_mesh",
    "wall_superpoints",
]
