"""The label-free front end on a tiny synthetic room: planes removed, objects found and rendered back
into every frame, labels 'object' without CLIP, zero-shot labels with a tiny random CLIP, and the
empty-scene error."""

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
