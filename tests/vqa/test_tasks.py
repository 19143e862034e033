"""Table 4 task types, metric distance bands, viewpoint estimation, the ambiguity filters of the new
templates, and the oracle: questions from a ground-truth scene are all answerable from it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rescene_core.vqa import VqaConfig, VqaObject, VqaScene, build_vqa, make_renderer, scene_from_synth_layout
from rescene_core.vqa.context import band_labels, distance_band, relative_yaw, yaw_sector
from rescene_core.vqa.items import TEMPLATE_TASKS, TaskType
from rescene_core.vqa.oracle import agreement, answer_on
from rescene_core.vqa.walk import AgentPose
from tests.vqa.scenes import CHAIR, make_bedroom

SMALL = dict(image_width=80, image_height=60, min_visible_pixels=10, per_category=1000)


def test_distance_bands_and_edges():
    edges = (0.5, 1.0, 2.0)
    assert band_labels(edges) == ["less than 0.5 m", "0.5-1.0 m", "1.0-2.0 m", "more than 2.0 m"]
    assert distance_band(1.5, edges, 0.1) == ("1.0-2.0 m", False)
    assert distance_band(1.95, edges, 0.1) == ("1.0-2.0 m", True)
    assert distance_band(0.2, edges, 0.1) == ("less than 0.5 m", False)
    assert distance_band(7.0, edges, 0.1) == ("more than 2.0 m", False)


def test_directions_relative_to_the_camera():
    wfc = AgentPose((0.0, 0.0, 1.5), 90.0, 0.0).world_from_cam()  # facing north (+y)
    assert relative_yaw(wfc, (0.0, 3.0, 0.0)) == pytest.approx(0.0)
    assert relative_yaw(wfc, (-2.0, 0.0, 0.0)) == pytest.approx(90.0)  # west is to the left
    assert yaw_sector(relative_yaw(wfc, (-2.0, 0.0, 0.0)), 10.0) == ("left", False)
    assert yaw_sector(relative_yaw(wfc, (2.0, 0.1, 0.0)), 10.0) == ("right", False)
    assert yaw_sector(relative_yaw(wfc, (0.0, -3.0, 0.0)), 10.0) == ("behind", False)
    assert yaw_sector(44.0, 10.0) == ("ahead", True)


def test_every_template_has_a_task_and_walks_cover_the_table4_tasks(bedroom):
    dataset = build_vqa(bedroom, VqaConfig(**SMALL, sampling="walk", walk_steps=24, seed=1))
    for item in dataset.items:
        assert item.template in TEMPLATE_TASKS and item.to_json()["task"] == item.task.value
    templates = {i.template for i in dataset.items}
    assert {"distance_between", "distance_to_camera", "count_in_view", "object_direction"} <= templates
    assert {t for t in TaskType} == {i.task for i in dataset.items}
    for item in dataset.items:
        if item.template in ("distance_between", "distance_to_camera"):
            d = item.provenance.get("center_distance_m", item.provenance.get("distance_m"))
            assert min(abs(e - d) for e in VqaConfig().distance_band_edges) >= VqaConfig().distance_band_margin - 1e-3


def test_count_in_view_skips_objects_near_the_pixel_threshold(bedroom):
    config = VqaConfig(**SMALL, sampling="walk", walk_steps=24, seed=1)
    dataset = build_vqa(bedroom, config)
    lo, hi = config.min_visible_pixels / config.visibility_margin, config.min_visible_pixels * config.visibility_margin
    counted = [i for i in dataset.items if i.template == "count_in_view"]
    assert counted
    for item in counted:
        assert all(not (lo <= n < hi) for n in item.provenance["pixels"].values())


@pytest.mark.parametrize("sampling", ["walk", "target"])
def test_ground_truth_questions_are_all_answerable_from_the_ground_truth(sampling):
    scene = scene_from_synth_layout("tiny", 0)
    config = VqaConfig(**SMALL, sampling=sampling, walk_steps=12, views=4, seed=2)
    dataset = build_vqa(scene, config)
    renderer = make_renderer(scene, config)  # view questions are re-checked on a fresh render
    assert len(dataset.items) > 30
    wrong = [(i.template, i.answer, answer_on(i, scene, config, renderer)) for i in dataset.items]
    wrong = [w for w in wrong if w[1] != w[2]]
    assert wrong == []
    assert agreement(dataset.items, scene, config, renderer)["agreement"] == 1.0


def test_agreement_drops_when_the_scene_is_wrong(bedroom):
    """A reconstruction that moved the chair and lost the lamp's edge disagrees on the questions about them."""
    config = VqaConfig(**SMALL, sampling="walk", walk_steps=24, seed=1)
    dataset = build_vqa(bedroom, config)
    objects = [
        VqaObject.box(o.id, o.label, o.center + np.array([-3.0, 2.0, 0.0]), o.size) if o.id == CHAIR else o
        for o in bedroom.objects
    ]
    moved = VqaScene(tuple(objects), make_bedroom().graph, bedroom.shell, scene_id="moved")
    moved = dataclasses.replace(moved, graph=type(moved.graph)(tuple(e for e in moved.graph.edges if e.child != 3)))
    result = agreement(dataset.items, moved, config)
    assert result["disagree"] > 0 and result["unanswerable"] > 0
    assert 0.0 < result["agreement"] < 1.0
    assert result["questions"] == len(dataset.items)
