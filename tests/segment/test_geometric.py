"""The label-free front end on a tiny synthetic room: planes removed, objects found and rendered back
into every frame, labels 'object' without CLIP, zero-shot labels with a tiny random CLIP, the
empty-scene error; on small point sets, a ceiling seen only along a wall (and a pendant lamp that is none)
and a shadow on a wall that is no flush object."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from flows.cli import main
from rescene_core.capture import open_capture
from rescene_core.capture.importers.layouts import write_rgbd
from rescene_core.capture.synth import make_scene
from rescene_core.segment import SegmentConfig, SegmentError, segment_geometric
from rescene_core.segment.evaluate import instance_scores, mask_iou_table, synth_object_sizes
from rescene_core.segment.geometric import ScanPoints, scan_points, wall_superpoints
from rescene_core.segment.geometric.structure import _structure


@pytest.fixture(scope="module")
def tiny():
    return make_scene("tiny", seed=0)


@pytest.fixture(scope="module")
def segmented(tiny):
    a = tiny.arrays
    return segment_geometric(a.rgb, a.depth, a.K, a.world_from_cam)


def test_structure_and_objects_are_found(tiny, segmented):
    kinds = [p["kind"] for p in segmented.report["planes"]]
    assert kinds.count("floor") == 1 and kinds.count("wall") >= 2
    objects = {i for i, (lab, st) in segmented.labels.items() if not st}
    assert objects and all(segmented.labels[i][0] == "object" for i in objects)
    assert segmented.segmenter == "geometric"
    # the large furniture (desk, chair) is recovered at mask IoU >= 0.5
    scores = instance_scores(segmented.masks, tiny.object_id_frames, objects, synth_object_sizes(tiny))
    assert scores["matched"] >= 2 and scores["precision"] >= 0.5
    # structure masks lie on ground-truth structure, not on objects
    floor = segmented.masks == 1
    assert (tiny.object_id_frames[floor] == 0).mean() > 0.95


def test_masks_agree_with_measured_depth(tiny, segmented):
    # a labelled pixel never contradicts the depth: ids come from surfaces the depth saw
    iou, gids, pids = mask_iou_table(segmented.masks, tiny.object_id_frames)
    assert iou.shape == (len(gids), len(pids))
    assert segmented.report["render"]["labelled"] > 0.5 * segmented.masks.size


def test_empty_room_is_a_clear_error(tiny):
    a = tiny.arrays
    cfg = SegmentConfig(min_segment_extent=50.0)  # nothing can be that big: no objects
    with pytest.raises(SegmentError, match="empty scene after segmentation"):
        segment_geometric(a.rgb, a.depth, a.K, a.world_from_cam, cfg)


@pytest.mark.slow
def test_import_rgbd_with_geometric_segments_via_cli(tiny, tmp_path, capsys):
    src = write_rgbd(tiny.arrays, tmp_path / "src")
    out = tmp_path / "room.zarr"
    code = main(["import", "rgbd", str(src), str(out), "--segment", "geometric", "--pictures"])
    text = capsys.readouterr().out
    assert code == 0, text
    cap = open_capture(out)
    assert cap.source == "rgbd+geometric" and cap.attrs["import"]["segmenter"] == "geometric"
    assert len(cap.object_instances) >= 1 and all(len(cap.point_cloud(i.id)) for i in cap.object_instances)
    assert (tmp_path / "room_contact.png").exists() and (tmp_path / "room_plan.png").exists()
    # the synthetic room is z up already: alignment keeps the floor at z = 0 and camera heights
    np.testing.assert_allclose(cap.world_from_cam[:, 2, 3], tiny.arrays.world_from_cam[:, 2, 3], atol=0.02)
    assert "by geometric" in text and "frames/s" in text


@pytest.mark.slow
def test_zero_shot_labels_with_a_tiny_random_clip(tiny, segmented, tmp_path):
    torch = pytest.importorskip("torch")
    open_clip = pytest.importorskip("open_clip")
    from rescene_core.segment.labels import zero_shot_labels

    name = "rescene-tiny-clip"  # a tiny random architecture built here: no weights are downloaded
    config = {
        "embed_dim": 16,
        "vision_cfg": {"image_size": 32, "layers": 1, "width": 32, "patch_size": 16, "head_width": 16},
        "text_cfg": {"context_length": 77, "vocab_size": 49408, "width": 32, "heads": 2, "layers": 1},
    }
    (tmp_path / f"{name}.json").write_text(json.dumps(config))
    open_clip.add_model_config(tmp_path)
    torch.manual_seed(0)
    weights = tmp_path / "clip.pt"
    torch.save(open_clip.create_model(name, pretrained=None).state_dict(), weights)
    objects = [i for i, (lab, st) in segmented.labels.items() if not st]
    vocab = ("chair", "desk", "lamp")
    names, report = zero_shot_labels(tiny.arrays.rgb, segmented.masks, objects, weights, name, vocab, views=2)
    assert set(names) == set(objects) and set(names.values()) <= set(vocab)
    assert report["labeller"] == f"open_clip {name}" and report["device"] in ("cpu", "cuda")
    for detail in report["segments"].values():
        assert 0.0 < detail["probability"] <= 1.0 and 1 <= len(detail["views"]) <= 2


def test_zero_shot_labels_without_torch_names_the_extra(tiny, segmented, monkeypatch, tmp_path):
    from rescene_core.segment.labels import zero_shot_labels

    monkeypatch.setitem(sys.modules, "torch", None)  # as if the clip extra were not installed
    objects = [i for i, (lab, st) in segmented.labels.items() if not st]
    with pytest.raises(SegmentError, match=r"pip install 'rescene\[clip\]'"):
        zero_shot_labels(tiny.arrays.rgb, segmented.masks, objects, tmp_path / "clip.pt", "ViT-B-32", ("chair",))


def _box_room(extra: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Vertices [v, 3] and unit normals [v, 3] of a 4 x 3 x 2.8 m room's floor and walls (5 cm grid, normals
    into the room) with no ceiling, plus the ``extra`` (points, normals) surfaces."""
    s = np.arange(0.0, 4.0, 0.05)
    t = np.arange(0.0, 3.0, 0.05)
    h = np.arange(0.0, 2.8, 0.05)
    fx, fy = np.meshgrid(s, t)
    parts = [(np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)], np.tile([0.0, 0.0, 1.0], (fx.size, 1)))]
    for along, fixed, axis, normal in ((s, 0.0, 1, [0, 1, 0]), (s, 3.0, 1, [0, -1, 0]),
                                       (t, 0.0, 0, [1, 0, 0]), (t, 4.0, 0, [-1, 0, 0])):  # fmt: skip
        a, z = np.meshgrid(along, h)
        p = np.zeros((a.size, 3))
        p[:, 1 - axis], p[:, axis], p[:, 2] = a.ravel(), fixed, z.ravel()
        parts.append((p, np.tile(np.asarray(normal, float), (a.size, 1))))
    parts += extra
    return np.concatenate([p for p, _ in parts]), np.concatenate([n for _, n in parts])


def _patch(x: tuple[float, float], y: tuple[float, float], z: float, normal_z: float) -> tuple[np.ndarray, np.ndarray]:
    """A horizontal patch (2 cm grid) at height z (m) facing up (normal_z 1) or down (-1)."""
    gx, gy = np.meshgrid(np.arange(*x, 0.02), np.arange(*y, 0.02))
    p = np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, z)]
    return p, np.tile([0.0, 0.0, normal_z], (len(p), 1))


def test_a_ceiling_seen_only_along_a_wall_is_structure():
    # a 16 cm strip of ceiling along one wall: too few points for the plane search, yet the room's top
    strip = _patch((0.02, 1.02), (0.02, 0.18), 2.8, -1.0)
    verts, normals = _box_room([strip])
    cams = np.array([[2.0, 1.5, 1.6], [1.0, 1.0, 1.5]])
    labels, planes = _structure(verts, normals, cams, SegmentConfig())
    ceiling = [p for p in planes if p["kind"] == "ceiling"]
    assert len(ceiling) == 1 and ceiling[0]["found_by"] == "downward slab"
    assert abs(ceiling[0]["height"] - 2.8) < 0.01
    assert (labels[-len(strip[0]) :] == ceiling[0]["id"]).all()
    assert sum(p["kind"] == "wall" for p in planes) == 4


def test_a_pendant_lamp_is_no_ceiling():
    # the underside of a shade hanging above the cameras, its top above it and no ceiling seen: no ceiling
    under = _patch((1.8, 2.2), (1.3, 1.7), 2.3, -1.0)
    above = _patch((1.85, 2.15), (1.35, 1.65), 2.55, 1.0)
    verts, normals = _box_room([under, above])
    cams = np.array([[2.0, 1.5, 1.6], [1.0, 1.0, 1.5]])
    labels, planes = _structure(verts, normals, cams, SegmentConfig())
    assert not [p for p in planes if p["kind"] == "ceiling"]
    assert (labels[-len(under[0]) - len(above[0]) :] == 0).all()


def _painted_wall() -> tuple[ScanPoints, list[dict], np.ndarray, np.ndarray]:
    """A 2 x 2 m wall (the plane x = 0, 1 cm grid) painted light grey, with a shadow (the grey darkened to
    70 %) and a brown picture flat on it; the scan points and the planes, with masks of the shadow's and the
    picture's vertices."""
    y, z = np.meshgrid(np.arange(0.0, 2.0, 0.01), np.arange(0.5, 2.5, 0.01))
    verts = np.c_[np.zeros(y.size), y.ravel(), z.ravel()]
    normals = np.tile([1.0, 0.0, 0.0], (len(verts), 1))
    shadow = (verts[:, 1] > 0.2) & (verts[:, 1] < 0.8) & (verts[:, 2] > 1.0) & (verts[:, 2] < 1.4)
    picture = (verts[:, 1] > 1.2) & (verts[:, 1] < 1.8) & (verts[:, 2] > 1.0) & (verts[:, 2] < 1.6)
    grey = np.array([0.8, 0.8, 0.82])
    colours = np.tile(grey, (len(verts), 1))
    colours[shadow] = 0.7 * grey
    colours[picture] = [0.55, 0.4, 0.25]
    wall = {"kind": "wall", "id": 2, "normal": [1.0, 0.0, 0.0], "offset": 0.0, "span": [-2.05, 0.05]}
    planes = [{"kind": "floor", "id": 1, "vertices": 0}, {**wall, "vertices": len(verts)}]
    struct = np.full(len(verts), 2, np.int64)
    return scan_points(verts, normals, colours, struct, planes, SegmentConfig()), planes, shadow, picture


def test_a_shadow_on_a_wall_is_no_flush_object():
    # a shadow keeps the wall's hue: unlike the picture it is no flush candidate, so it cannot join the
    # shelf that casts it; with the shadow test off, colour alone made it one
    sp, planes, shadow, picture = _painted_wall()

    def flush_of_vertex(cfg: SegmentConfig) -> np.ndarray:
        return wall_superpoints(sp, planes, cfg)[1][sp.graph.label[sp.vertex_point]]

    flush = flush_of_vertex(SegmentConfig())
    assert flush[shadow].mean() < 0.1 and flush[picture].mean() > 0.9
    assert flush_of_vertex(SegmentConfig(flush_shadow_tint=0.0))[shadow].mean() > 0.9


def _wall(a: tuple[float, float], b: tuple[float, float], height: float = 2.6) -> tuple[np.ndarray, np.ndarray]:
    """An upright wall (5 cm grid) from floor point a to b (m), its normal to the left of a -> b."""
    a_, b_ = np.asarray(a, float), np.asarray(b, float)
    run = b_ - a_
    s, z = np.meshgrid(np.arange(0.0, np.linalg.norm(run), 0.05), np.arange(0.0, height, 0.05))
    xy = a_ + np.outer(s.ravel(), run / np.linalg.norm(run))
    normal = np.array([-run[1], run[0], 0.0]) / np.linalg.norm(run)
    return np.c_[xy, z.ravel()], np.tile(normal, (len(xy), 1))


def test_the_inner_walls_of_an_l_shaped_room_are_walls_a_face_on_a_wall_is_not():
    # a 5 x 2.5 m room with a 3 x 1.5 m wing (x < 3, 2.5 < y < 4); walls run anticlockwise, normals inwards
    corners = [(0.0, 0.0), (5.0, 0.0), (5.0, 2.5), (3.0, 2.5), (3.0, 4.0), (0.0, 4.0), (0.0, 0.0)]
    parts = [_wall(a, b) for a, b in zip(corners[:-1], corners[1:], strict=True)]
    gx, gy = np.meshgrid(np.arange(0.0, 5.0, 0.05), np.arange(0.0, 4.0, 0.05))
    floor = np.c_[gx.ravel(), gy.ravel(), np.zeros(gx.size)][(gx.ravel() < 3.0) | (gy.ravel() < 2.5)]
    parts.append((floor, np.tile([0.0, 0.0, 1.0], (len(floor), 1))))
    # a wardrobe's side in the wing, in line with the inner wall y = 2.5: its plane's span runs past the corner
    parts.append(_wall((2.9, 2.5), (2.3, 2.5), 2.0))
    # a bookcase's side 1.7 degrees off the wall x = 0 (2 to 7 cm in front of it; its plane meets the wall's
    # far beyond its end), hiding the wall behind it: no wall of its own
    side = _wall((0.0, 2.7), (0.0, 1.1), 2.0)
    side[0][:, 0] += 0.03 * side[0][:, 1] - 0.01
    left = parts[5][0]
    hidden = (left[:, 1] > 1.1) & (left[:, 1] < 2.7) & (left[:, 2] < 2.0)
    parts[5] = (left[~hidden], parts[5][1][~hidden])
    parts.append(side)
    verts, normals = np.concatenate([p for p, _ in parts]), np.concatenate([n for _, n in parts])
    cams = np.array([[2.5, 1.2, 1.5], [1.5, 2.0, 1.5], [1.5, 3.2, 1.5]])
    labels, planes = _structure(verts, normals, cams, SegmentConfig())
    walls = [p for p in planes if p["kind"] == "wall"]
    assert len(walls) == 6
    inner = next(w for w in walls if abs(abs(w["normal"][1]) - 1) < 0.01 and abs(abs(w["offset"]) - 2.5) < 0.05)
    span = sorted(abs(v) for v in inner["span"])
    assert span[0] >= 2.95  # trimmed at the corner: the wardrobe's side is not wall
    wardrobe = slice(-len(side[0]) - len(parts[-2][0]), -len(side[0]))
    assert (labels[wardrobe] == 0).mean() > 0.9


def test_a_walls_stretch_loses_the_ends_with_the_room_behind_a_face_with_the_room_behind_its_middle_goes():
    from rescene_core.segment.geometric.structure import _trim_overhang

    cfg = SegmentConfig()
    rng = np.random.default_rng(0)
    # the scene's points along a plane's 3 m stretch (m along it) and their signed distances from it (m,
    # positive towards the room): 40 points a 10 cm bin, all in the room
    along = rng.uniform(0.0, 3.0, 1200)
    side = rng.uniform(0.1, 3.0, 1200)
    assert _trim_overhang(along, side, 0.0, 3.0, cfg) == (0.0, 3.0)
    # an inner wall's plane running on past the corner at 2.2 m across the room's other arm, whose points lie
    # behind the plane there: the stretch ends at the corner
    arm = along > 2.2
    lo, hi = _trim_overhang(along, np.where(arm, -side, side), 0.0, 3.0, cfg)
    assert lo == 0.0 and 2.15 <= hi <= 2.3
    # a wardrobe's front standing in the room before the inner wall it hides: the room lies behind it at
    # its ends and, past its top, over a stretch between them as well; no wall is left of it
    middle = (along > 1.2) & (along < 1.4)
    lo, hi = _trim_overhang(along, np.where(arm | middle, -side, side), 0.0, 3.0, cfg)
    assert hi - lo == 0.0
