"""render_overlay gives a thread its last result again for the same capture, frame and config (the relation
stage renders each key frame's overlay for the predictor and again to save it)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from rescene_core.config import SceneGraphConfig
from rescene_core.scenegraph.frame import render_overlay


def test_a_threads_second_rendering_of_a_frame_is_its_first(room_capture):
    config = SceneGraphConfig()
    first = render_overlay(room_capture, 0, config)
    assert render_overlay(room_capture, 0, config) is first
    other = render_overlay(room_capture, 1, config)
    assert other is not first
    again = render_overlay(room_capture, 0, config)  # another frame came between: rendered again
    assert again is not first
    np.testing.assert_array_equal(np.asarray(again[1]), np.asarray(first[1]))
    assert again[2] == first[2]
    bigger = config.model_copy(update={"overlay_font_px": config.overlay_font_px + 4})
    assert render_overlay(room_capture, 0, bigger) is not again  # another config is another overlay
    with ThreadPoolExecutor(1) as pool:  # another thread renders its own
        theirs = pool.submit(render_overlay, room_capture, 0, config).result()
    assert theirs is not again
    np.testing.assert_array_equal(np.asarray(theirs[1]), np.asarray(first[1]))
