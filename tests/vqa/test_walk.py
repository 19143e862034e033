"""The agent's egocentric walk: navigable start, fixed eye height, discrete actions with collision checks,
a capture per step with visibility from the id buffer; deterministic for a seed."""

from __future__ import annotations

import numpy as np
import pytest
from shapely import contains_xy
from shapely.geometry import Point

from rescene_core.vqa import VqaConfig, build_vqa, make_renderer
from rescene_core.vqa.render import free_space
from rescene_core.vqa.walk import AgentPose, random_start, step, walk_viewpoints

SMALL = dict(sampling="walk", image_width=80, image_height=60, min_visible_pixels=10)


def test_walk_is_deterministic_and_stays_navigable(bedroom):
    config = VqaConfig(**SMALL, walk_steps=20)
    renderer = make_renderer(bedroom, config)
    free = free_space(bedroom, config)
    a, _ = walk_viewpoints(bedroom, config, renderer, np.random.default_rng(3))
    b, _ = walk_viewpoints(bedroom, config, renderer, np.random.default_rng(3))
    c, _ = walk_viewpoints(bedroom, config, renderer, np.random.default_rng(4))
    assert a and [v.to_json() for v in a] == [v.to_json() for v in b]
    assert [v.to_json() for v in a] != [v.to_json() for v in c]
    for vp in a:
        eye = vp.eye
        assert contains_xy(free, eye[0], eye[1])
        assert eye[2] == pytest.approx(bedroom.floor_height() + config.walk_eye_height)
        assert abs(vp.agent["pitch_deg"]) <= config.walk_look_max_deg + 1e-9
        assert all(n >= config.min_visible_pixels for n in vp.visible.values())
        assert all(n < config.min_visible_pixels for n in vp.faint.values())
        assert vp.agent["action"] in ("forward", "blocked", "turn_left", "turn_right", "look_up", "look_down")


def test_forward_moves_are_collision_checked(bedroom):
    config = VqaConfig(**SMALL, walk_step_m=0.6)
    free = free_space(bedroom, config)
    rng = np.random.default_rng(0)
    # facing the chair (at x = 4, y = 1) from the west: the move would enter its grown footprint
    pose = AgentPose((3.0, 1.0, 1.5), 0.0, 0.0)
    assert contains_xy(free, 3.0, 1.0)
    moved, done = step(pose, "forward", config, free, rng)
    assert done == "blocked" and moved.eye == pose.eye and moved.yaw_deg in (30.0, 330.0)
    # facing west into open floor: it moves by walk_step_m
    moved, done = step(AgentPose((3.0, 1.0, 1.5), 180.0, 0.0), "forward", config, free, rng)
    assert done == "forward" and moved.eye[0] == pytest.approx(2.4)
    # only forward moves: every position of a long walk stays in the free space
    walker = VqaConfig(**SMALL, walk_steps=40, walk_action_probs=(1.0, 0.0, 0.0, 0.0, 0.0))
    views, _ = walk_viewpoints(bedroom, walker, make_renderer(bedroom, walker), np.random.default_rng(1))
    actions = [v.agent["action"] for v in views]
    assert "blocked" in actions
    assert all(free.buffer(1e-9).contains(Point(v.eye[:2])) for v in views)


def test_start_is_outside_object_footprints(bedroom):
    config = VqaConfig(**SMALL)
    free = free_space(bedroom, config)
    for seed in range(20):
        pose = random_start(bedroom, config, free, np.random.default_rng(seed))
        x, y, _ = pose.eye
        for o in bedroom.objects:
            inside = o.box_min[0] <= x <= o.box_max[0] and o.box_min[1] <= y <= o.box_max[1]
            assert not inside


def test_walk_views_give_all_four_table4_tasks(bedroom):
    dataset = build_vqa(bedroom, VqaConfig(**SMALL, walk_steps=24, per_category=100, seed=1))
    tasks = dataset.summary["task_counts"]
    assert all(tasks[t] > 0 for t in ("object_count", "distance_judgement", "relation_reasoning"))
    assert tasks["viewpoint_estimation"] > 0
    assert set(dataset.images) == {vp.id for vp in dataset.viewpoints}
