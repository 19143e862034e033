"""``--segment masks``: the truth's masks damaged as a 2D segmenter's are, lifted back into 3D instances by
view consensus over superpoints (API and CLI), and the mask folder's errors."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from flows.cli import main
from rescene_core.capture import open_capture
from rescene_core.capture.importers.layouts import write_rgbd
from rescene_core.capture.synth import make_scene
from rescene_core.segment import SegmentError
from rescene_core.segment.damage import MaskDamage, damage_masks
from rescene_core.segment.evaluate import instance_scores, synth_object_sizes
from rescene_core.segment.lift import read_mask_dir


@pytest.fixture(scope="module")
def room():
    # the tiny room at 320 x 240 and 24 frames: at 160 x 120 a few pixels of damaged outline are a whole part
    return make_scene("tiny", seed=0, width=320, height=240, frames=24)


@pytest.fixture(scope="module")
def damaged(room):
    return damage_masks(room.object_id_frames, np.random.default_rng(0), MaskDamage(boundary_px=2))


def test_damage_is_what_a_2d_segmenter_does(room, damaged):
    truth = room.object_id_frames
    missing = [t for t, m in enumerate(damaged) if m is None]
    assert len(missing) == round(0.15 * len(truth))
    kept = [t for t in range(len(truth)) if t not in missing]
    # ids are not consistent across frames: the largest object takes different ids in different frames
    big = np.bincount(truth.ravel())[1:].argmax() + 1
    ids = set()
    for t in kept:
        sel = truth[t] == big
        if sel.sum() > 500:
            vals, cnt = np.unique(damaged[t][sel], return_counts=True)
            ids.add(int(vals[cnt.argmax()]))
    assert len(ids) >= 3
    # some object is split in some frame (two ids over one object's pixels), outlines moved, mask shapes kept
    splits = sum(
        len(np.unique(damaged[t][(truth[t] == i) & (damaged[t] > 0)])) >= 2
        for t in kept
        for i in np.unique(truth[t])
        if i > 0 and (truth[t] == i).sum() > 200
    )
    assert splits >= 1
    changed = np.mean([((damaged[t] > 0) != (truth[t] > 0)).mean() for t in kept])
    assert 0.0 < changed < 0.2
    assert all(damaged[t].shape == truth[t].shape for t in kept)


def test_mask_folder_errors(tmp_path):
    names = ["000000", "000001"]
    with pytest.raises(SegmentError, match="no such folder"):
        read_mask_dir(tmp_path / "nope", names, 4, 6)
    (tmp_path / "m").mkdir()
    with pytest.raises(SegmentError, match="no PNG files"):
        read_mask_dir(tmp_path / "m", names, 4, 6)
    Image.fromarray(np.zeros((4, 6), np.uint8)).save(tmp_path / "m" / "other.png")
    with pytest.raises(SegmentError, match="named like a frame"):
        read_mask_dir(tmp_path / "m", names, 4, 6)
    Image.fromarray(np.zeros((5, 6), np.uint8)).save(tmp_path / "m" / "000001.png")
    with pytest.raises(SegmentError, match=r"000001.png: a 6 x 5 mask for 6 x 4 frames"):
        read_mask_dir(tmp_path / "m", names, 4, 6)
    ids = np.array([[0, 1, 2, 2, 300, 300]] * 4, np.uint16)
    Image.fromarray(ids).save(tmp_path / "m" / "000001.png")
    rgb = np.zeros((4, 6, 3), np.uint8)
    rgb[:, 3:, 1] = 7  # colour-coded ids: (0, 7, 0) -> 7 * 256
    Image.fromarray(rgb).save(tmp_path / "m" / "000000.png")
    got = read_mask_dir(tmp_path / "m", names, 4, 6)
    assert got[0] is not None and set(np.unique(got[0]).tolist()) == {0, 7 * 256}
    assert got[1] is not None and np.array_equal(got[1], ids)
    assert read_mask_dir(tmp_path / "m", ["000001", "000009"], 4, 6)[1] is None  # a frame without a mask


@pytest.mark.slow
def test_import_rgbd_with_masks_via_cli(room, damaged, tmp_path, capsys):
    src = write_rgbd(room.arrays, tmp_path / "src")
    names = sorted(p.stem for p in (src / "images").iterdir())
    assert names and len(names) == len(damaged)
    mask_dir = tmp_path / "sam2"
    mask_dir.mkdir()
    for name, m in zip(names, damaged, strict=True):
        if m is not None:
            Image.fromarray(m.astype(np.uint16)).save(mask_dir / f"{name}.png")
    out = tmp_path / "room.zarr"
    code = main(["import", "rgbd", str(src), str(out), "--segment", "masks", "--masks", str(mask_dir)])
    text = capsys.readouterr().out
    assert code == 0, text
    cap = open_capture(out)
    assert cap.source == "rgbd+masks" and cap.attrs["import"]["segmenter"] == "masks"
    assert "4 of 24 frames have no mask" in text
    objects = {int(i.id) for i in cap.object_instances}
    assert all(i.label == "object" for i in cap.object_instances)
    scores = instance_scores(
        np.asarray(cap.instance_masks[...]), room.object_id_frames, objects, synth_object_sizes(room)
    )
    # measured: all 5 objects > 20 cm (desk, chair, monitor, book stack, the picture on the wall) at IoU >= 0.5
    assert scores["recall_large"] >= 0.8 and scores["precision"] >= 0.8, scores
    # --segment masks without --masks, and --masks without --segment masks: clear errors, exit 2
    assert main(["import", "rgbd", str(src), str(tmp_path / "b.zarr"), "--segment", "masks"]) == 2
    assert "needs --masks DIR" in capsys.readouterr().err
    assert main(["import", "rgbd", str(src), str(tmp_path / "c.zarr"), "--masks", str(mask_dir)]) == 2
    assert "add --segment masks" in capsys.readouterr().err


def test_consensus_keeps_a_stack_apart_from_its_shelf_across_straddling_superpoints():
    from types import SimpleNamespace

    from rescene_core.segment.geometric import SegmentConfig
    from rescene_core.segment.lift import FrameCounts
    from rescene_core.segment.masks import consensus_regions

    # a chain stack (0) - straddling (1) - straddling (2) - shelf (3), seen in 10 frames: the stack reads
    # its own id, the shelf another; superpoint 1 reads the stack's id in frames 0-7, superpoint 2 in
    # frames 0-3 and the shelf's elsewhere. Every touching pair agrees in at least 60 % of the frames, so
    # joining pairs of superpoints would make one region of all four; the stack as a whole never reads the
    # shelf's id.
    rows = []
    for t in range(10):
        stack_id, shelf_id = 10 + t, 50 + t  # ids differ from frame to frame
        rows += [(0, t, stack_id, 40), (3, t, shelf_id, 40)]
        rows.append((1, t, stack_id if t < 8 else shelf_id, 5))
        rows.append((2, t, stack_id if t < 4 else shelf_id, 5))
    sp_, frame, ids, count = (np.array(c, np.int64) for c in zip(*sorted(rows), strict=True))
    graph = SimpleNamespace(size=4, pairs=np.array([[0, 1], [1, 2], [2, 3]]), contacts=np.array([9, 9, 9]))
    region, stats = consensus_regions(
        SimpleNamespace(graph=graph), FrameCounts(sp_, frame, ids, count), 10, SegmentConfig()
    )
    assert region[0] == region[1] != region[3] == region[2]
    assert region.min() > 0 and stats["joined_by_consensus"] == 2


def test_a_superpoint_the_masks_cut_is_split_between_its_regions():
    from rescene_core.segment.geometric import ScanPoints, SegmentConfig
    from rescene_core.segment.lift import FrameCounts
    from rescene_core.segment.masks import region_votes, split_straddling
    from rescene_core.segment.superpoints import edge_weights, point_graph, superpoint_graph

    # a 1 m x 0.5 m board 2 m in front of a camera, 2.5 cm points; superpoint 0 holds the left half and a
    # 10 cm strip of the right (a book's edge fused with its shelf), superpoint 1 the rest of the right
    xs, ys = np.meshgrid(np.arange(-0.5, 0.5, 0.025) + 0.0125, np.arange(-0.25, 0.25, 0.025) + 0.0125)
    points = np.c_[xs.ravel(), ys.ravel(), np.full(xs.size, 2.0)]
    normals = np.tile([0.0, 0.0, -1.0], (len(points), 1))
    colours = np.full((len(points), 3), 0.5)
    label = (points[:, 0] > 0.1).astype(np.int64)
    edges = point_graph(points, 0.04)
    _, concave, step = edge_weights(points, normals, colours, edges, 1.0)
    graph = superpoint_graph(points, normals, colours, label, edges, concave, step)
    sp = ScanPoints(
        points, normals, colours, np.zeros(len(points), np.int64), np.zeros(0, np.int64), edges, concave, step, graph
    )
    T, H, W = 6, 240, 320
    K = np.tile(np.array([[200.0, 0, 160], [0, 200.0, 120], [0, 0, 1]]), (T, 1, 1))
    world_from_cam = np.tile(np.eye(4), (T, 1, 1))
    depth = np.full((T, H, W), 2.0, np.float32)
    # each frame's masks part the board at x = 0 (pixel column 160), with ids drawn anew in every frame
    masks = [np.where(np.arange(W)[None, :] < 160, 3 + 2 * t, 4 + 2 * t) * np.ones((H, 1), np.int64) for t in range(T)]
    region = np.array([1, 2])
    reads = [(s, t, int(masks[t][120, 80 if s == 0 else 300]), 40) for s in (0, 1) for t in range(T)]
    counts = FrameCounts(*(np.array(c, np.int64) for c in zip(*sorted(reads), strict=True)))
    votes = region_votes(counts, region, T, SegmentConfig())
    assert votes.shape == (3, T) and (votes[0] == -1).all() and (votes[1] != votes[2]).all()
    sp2, region2, moved = split_straddling(sp, region, votes, masks, K, world_from_cam, depth, SegmentConfig())
    point_region = region2[sp2.graph.label]
    strip = (points[:, 0] > 0.0) & (points[:, 0] <= 0.1)
    assert moved == strip.sum() > 0
    assert (point_region[strip] == 2).all() and (point_region[points[:, 0] < 0] == 1).all()
    assert (point_region[points[:, 0] > 0.1] == 2).all() and sp2.graph.size == 3


def test_regions_parted_by_an_unmasked_gap_join_when_the_views_agree():
    from types import SimpleNamespace

    from rescene_core.segment.geometric import SegmentConfig
    from rescene_core.segment.lift import FrameCounts
    from rescene_core.segment.masks import bridge_gaps

    # four 20 cm blobs of 2.5 cm points along x: a lamp's shade (0) and base (1) 10 cm apart (the pole
    # between them unmasked), a nightstand (2) 10 cm beyond the base that a damaged mask gives the lamp's
    # id in 2 of 8 frames, and a second lamp (3) 1.5 m away that reads the first one's id in every frame
    # (no segmenter does that, but only nearness may let regions join across a gap)
    blob = np.stack(np.meshgrid(*[np.arange(0.0, 0.2, 0.025)] * 3, indexing="ij"), -1).reshape(-1, 3)
    starts = [0.0, 0.3, 0.6, 2.0]
    points = np.concatenate([blob + [x, 0.0, 0.0] for x in starts])
    label = np.repeat(np.arange(4), len(blob))
    rows = []
    for t in range(8):
        lamp, stand = 10 + t, 50 + t  # ids drawn anew in every frame
        rows += [(0, t, lamp, 30), (1, t, lamp, 30), (3, t, lamp, 30)]
        rows.append((2, t, lamp if t < 2 else stand, 30))
    counts = FrameCounts(*(np.array(c, np.int64) for c in zip(*sorted(rows), strict=True)))
    sp = SimpleNamespace(points=points, graph=SimpleNamespace(label=label, count=np.bincount(label)))
    region, joined = bridge_gaps(sp, np.array([1, 2, 3, 4]), counts, SegmentConfig())
    assert joined == 1 and region[0] == region[1]
    assert len({int(region[0]), int(region[2]), int(region[3])}) == 3
    # five frames at least: the same two blobs seen in only four do not join
    few = FrameCounts(*(c[counts.frame < 4] for c in (counts.sp, counts.frame, counts.mask_id, counts.count)))
    assert bridge_gaps(sp, np.array([1, 2, 3, 4]), few, SegmentConfig())[1] == 0
