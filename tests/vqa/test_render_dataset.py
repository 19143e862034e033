"""Viewpoint sampling, rendered views, the written data set, answer scoring and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image
from shapely.geometry import Point, box

from rescene_core.vqa import (
    Filter,
    VqaConfig,
    VqaInputError,
    build_vqa,
    evaluate_answers,
    look_at,
    make_renderer,
    read_questions,
    sample_viewpoints,
    write_vqa,
)

SMALL = VqaConfig(views=3, image_width=96, image_height=72, per_category=6, min_visible_pixels=20)


def test_look_at_is_an_opencv_camera_without_roll():
    m = look_at((0.0, 0.0, 1.5), (0.0, 2.0, 1.5))
    assert np.allclose(m[:3, 2], [0, 1, 0])  # z forward = north
    assert np.allclose(m[:3, 0], [1, 0, 0])  # x right = east
    assert np.allclose(m[:3, 1], [0, 0, -1])  # y down
    assert np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3))
    with pytest.raises(ValueError):
        look_at((0, 0, 1), (0, 0, 3))


def test_viewpoints_are_inside_free_space_and_see_their_target(bedroom):
    rng = np.random.default_rng(0)
    views, frames = sample_viewpoints(bedroom, SMALL, make_renderer(bedroom, SMALL), rng)
    assert len(views) == SMALL.views == len(frames)
    room = bedroom.shell.polygon().buffer(-SMALL.wall_clearance + 1e-9)
    for k, vp in enumerate(views):
        eye = vp.eye
        assert room.contains(Point(eye[0], eye[1]))
        assert SMALL.eye_height_min <= eye[2] - bedroom.floor_height() <= SMALL.eye_height_max
        for o in bedroom.objects:
            footprint = box(o.box_min[0], o.box_min[1], o.box_max[0], o.box_max[1])
            assert footprint.distance(Point(eye[0], eye[1])) >= SMALL.object_clearance - 1e-9
        assert vp.visible[vp.target] >= SMALL.min_visible_pixels
        assert frames[k].rgb.shape == (72, 96, 3)
        # the camera looks at the target: its box centre projects to the image centre
        uv, z = vp.camera.project(bedroom.object(vp.target).center[None])
        assert z[0] > 0 and np.allclose(uv[0], [48, 36], atol=1.0)


def test_no_free_space_is_a_clear_error(bedroom):
    with pytest.raises(VqaInputError, match="free floor space"):
        sample_viewpoints(
            bedroom, VqaConfig(views=1, wall_clearance=3.0), make_renderer(bedroom, SMALL), np.random.default_rng(0)
        )


def test_written_dataset(bedroom, tmp_path):
    dataset = build_vqa(bedroom, SMALL)
    paths = write_vqa(dataset, tmp_path / "vqa")
    lines = paths["questions"].read_text().splitlines()
    assert len(lines) == len(dataset.items) > 0
    items = read_questions(paths["questions"])
    assert [i.to_json() for i in items] == [json.loads(line) for line in lines]
    summary = json.loads(paths["summary"].read_text())
    assert summary["questions"] == len(items)
    assert sum(summary["counts"].values()) == len(items)
    assert summary["render_backend"] == "open3d-raycast"
    assert summary["config"]["seed"] == SMALL.seed
    assert set(summary["filtered_total"]) <= {f.value for f in Filter}
    pngs = sorted(p.name for p in (tmp_path / "vqa" / "views").glob("*.png"))
    assert pngs == [f"{vp.id}.png" for vp in dataset.viewpoints]
    img = np.asarray(Image.open(tmp_path / "vqa" / "views" / pngs[0]))
    assert img.shape == (72, 96, 3) and img.std() > 0
    for item in items:
        if item.viewpoint is not None:
            assert (tmp_path / "vqa" / item.viewpoint["image"]).is_file()
    # same seed, same data set
    again = build_vqa(bedroom, SMALL)
    assert [i.to_json() for i in again.items] == [i.to_json() for i in dataset.items]
    assert all(np.array_equal(again.images[k], dataset.images[k]) for k in dataset.images)


def test_evaluate_answers(bedroom):
    items = build_vqa(bedroom, VqaConfig(views=0)).items
    perfect = evaluate_answers(items, {i.id: i.answer for i in items})
    assert perfect["overall"]["accuracy"] == 1.0 and perfect["unanswered"] == 0
    for cat, row in perfect["per_category"].items():
        assert row["total"] == sum(1 for i in items if i.category.value == cat)
    letters = [{"id": i.id, "answer": "ABCD"[i.choices.index(i.answer)]} for i in items]
    assert evaluate_answers(items, letters)["overall"]["accuracy"] == 1.0
    wrong = {i.id: next(c for c in i.choices if c != i.answer) for i in items}
    assert evaluate_answers(items, wrong)["overall"]["correct"] == 0
    half = {i.id: f"The {i.answer.upper()}." for i in items[: len(items) // 2]}
    scored = evaluate_answers(items, half)
    assert scored["overall"]["correct"] == len(half) and scored["unanswered"] == len(items) - len(half)
