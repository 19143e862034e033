import io

import numpy as np
from PIL import Image

from rescene_core.config import SceneGraphConfig
from rescene_core.records import Camera
from rescene_core.scenegraph.overlay import overlay_ids, png_bytes
from rescene_core.scenegraph.view import FrameView, VisibleInstance, frame_view


def test_labels_sit_inside_their_masks_without_overlapping(room_capture):
    cfg = SceneGraphConfig()
    for t in range(room_capture.num_frames):
        view = frame_view(room_capture, t, cfg)
        image, placements = overlay_ids(view, font_px=12)
        assert image.size == (view.mask.shape[1], view.mask.shape[0])
        assert [p.display for p in placements] == [v.display for v in view.visible]
        boxes = [p.box for p in placements]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1], (t, a, b)
        for p, v in zip(placements, view.visible):
            if p.inside_mask:
                x0, y0, x1, y1 = p.box
                assert (view.mask[y0:y1, x0:x1] == v.instance).all()
            cx, cy = p.center
            assert view.mask[cy, cx] == v.instance or not p.inside_mask


def test_crowded_masks_still_get_separate_labels():
    h, w = 60, 120
    mask = np.zeros((h, w), np.int32)
    for k in range(4):
        mask[10:50, k * 30 : k * 30 + 30] = k + 1
    visible = tuple(VisibleInstance(k + 1, k + 1, "box", 1200) for k in range(4))
    cam = Camera(np.array([[50.0, 0, 60], [0, 50, 30], [0, 0, 1]]), np.eye(4), w, h)
    view = FrameView(0, cam, np.zeros((h, w, 3), np.uint8), mask, None, visible)
    image, placements = overlay_ids(view, font_px=14)
    assert all(p.inside_mask and not p.overlaps for p in placements)
    # the digit pixels are drawn (yellow) inside each box
    arr = np.asarray(image)
    for p in placements:
        x0, y0, x1, y1 = p.box
        assert (arr[y0:y1, x0:x1, 0] > 200).any()
    decoded = Image.open(io.BytesIO(png_bytes(image)))
    assert decoded.format == "PNG" and decoded.size == (w, h)


def test_min_visible_pixels_hides_small_instances(room_capture):
    small = frame_view(room_capture, 0, SceneGraphConfig(min_visible_pixels=1))
    large = frame_view(room_capture, 0, SceneGraphConfig(min_visible_pixels=1000))
    assert len(large.visible) < len(small.visible)
    assert all(v.pixels >= 1000 for v in large.visible)
    assert [v.display for v in small.visible] == list(range(1, len(small.visible) + 1))
