"""A VQA data set for one scene: sample and render viewpoints, generate questions, write RUN/vqa/.

Files (written atomically):

- ``questions.jsonl``: one ``VqaItem.to_json()`` per line;
- ``views/<view id>.png``: the rendered RGB view of every sampled viewpoint;
- ``summary.json``: counts per category, candidates, filtered counts by reason, viewpoints, config.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.io import write_bytes_atomic, write_json_atomic
from rescene_core.paths import VQA, VQA_QUESTIONS, VQA_SUMMARY, VQA_VIEW, VQA_VIEWS, RunPaths, in_folder
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.generate import Category, GeneratedQuestions, VqaItem, generate_questions
from rescene_core.vqa.render import RENDER_BACKEND, Viewpoint, make_renderer, sample_viewpoints, save_png
from rescene_core.vqa.scene import VqaInputError, VqaScene, read_run
from rescene_core.vqa.walk import walk_viewpoints

SUMMARY_FORMAT = "rescene-vqa"


@dataclass
class VqaDataset:
    """Items, the viewpoints they use, the rendered RGB images (uint8 [H, W, 3] per view id), and a summary."""

    items: list[VqaItem]
    viewpoints: list[Viewpoint]
    images: dict[str, np.ndarray]
    summary: dict[str, Any]


def build_vqa(scene: VqaScene, config: VqaConfig | None = None) -> VqaDataset:
    """Sample ``config.views`` viewpoints, render them, and generate the questions (deterministic by seed)."""
    config = config or VqaConfig()
    rng = np.random.default_rng(config.seed)
    viewpoints: list[Viewpoint] = []
    images: dict[str, np.ndarray] = {}
    if config.sampling == "walk" and config.walks > 0:
        viewpoints, frames = walk_viewpoints(scene, config, make_renderer(scene, config), rng)
        images = {vp.id: frames[k].rgb for k, vp in enumerate(viewpoints)}
    elif config.sampling == "target" and config.views > 0:
        renderer = make_renderer(scene, config)
        viewpoints, frames = sample_viewpoints(scene, config, renderer, rng)
        images = {vp.id: frames[k].rgb for k, vp in enumerate(viewpoints)}
    generated = generate_questions(scene, config, viewpoints)
    return VqaDataset(generated.items, viewpoints, images, _summary(scene, config, viewpoints, generated))


def _summary(scene: VqaScene, config: VqaConfig, viewpoints: list[Viewpoint], gen: GeneratedQuestions) -> dict:
    filtered_total: dict[str, int] = {}
    for reasons in gen.filtered.values():
        for reason, n in reasons.items():
            filtered_total[reason] = filtered_total.get(reason, 0) + n
    return {
        "format": SUMMARY_FORMAT,
        "version": 1,
        "scene": {"id": scene.scene_id, "source": scene.source, "objects": len(scene.objects)},
        "render_backend": RENDER_BACKEND,
        "questions": len(gen.items),
        "counts": gen.counts(),
        "task_counts": gen.task_counts(),
        "skipped": scene.skipped_json(),
        "candidates": gen.candidates,
        "filtered": gen.filtered,
        "filtered_total": dict(sorted(filtered_total.items())),
        "views": [vp.to_json() for vp in viewpoints],
        "views_requested": config.views if config.sampling == "target" else config.walks * config.walk_steps,
        "config": config.model_dump(),
    }


def write_vqa(dataset: VqaDataset, out_dir: str | Path) -> dict[str, Path]:
    """Write questions.jsonl, views/*.png and summary.json under ``out_dir``; returns their paths."""
    for view_id, rgb in sorted(dataset.images.items()):
        save_png(in_folder(out_dir, VQA_VIEW, VQA, view=view_id), rgb)
    lines = "".join(json.dumps(item.to_json()) + "\n" for item in dataset.items)
    questions = write_bytes_atomic(in_folder(out_dir, VQA_QUESTIONS, VQA), lines.encode())
    summary = write_json_atomic(in_folder(out_dir, VQA_SUMMARY, VQA), dataset.summary)
    return {"questions": questions, "summary": summary, "views": in_folder(out_dir, VQA_VIEWS, VQA)}


def vqa_for_run(run_dir: str | Path, out_dir: str | Path | None = None, config: VqaConfig | None = None) -> dict:
    """Read an assembled run, build its VQA data and write it to ``out_dir`` (default RUN/vqa); returns the
    summary."""
    scene = read_run(run_dir)
    dataset = build_vqa(scene, config)
    write_vqa(dataset, RunPaths(run_dir).vqa if out_dir is None else out_dir)
    return dataset.summary


def read_questions(path: str | Path) -> list[VqaItem]:
    """Items from a questions.jsonl file."""
    path = Path(path)
    if not path.is_file():
        raise VqaInputError(f"{path}: no such questions file")
    return [VqaItem.from_json(json.loads(line)) for line in path.read_text().splitlines() if line.strip()]


def normalise_answer(text: str) -> str:
    """Lower case, trimmed, without a leading article or trailing full stop ('The Lamp.' -> 'lamp')."""
    t = " ".join(str(text).strip().lower().rstrip(".").split())
    for article in ("the ", "a ", "an "):
        if t.startswith(article):
            t = t[len(article) :]
    return t


def evaluate_answers(
    questions: Iterable[VqaItem], answers: Mapping[str, str] | Iterable[Mapping[str, Any]]
) -> dict[str, Any]:
    """Score a model's answers: accuracy per category and overall.

    answers: question id -> answer text, or records ``{"id", "answer"}``. An answer counts when it equals
    the item's answer after ``normalise_answer``, or when it is the letter of the right choice ('A' is the
    first choice). Unanswered questions count as wrong.
    Returns {"per_category": {category: {"correct", "total", "accuracy"}}, "overall": {...}, "unanswered"}.
    """
    if isinstance(answers, Mapping):
        given = {str(k): str(v) for k, v in answers.items()}
    else:
        given = {str(a["id"]): str(a["answer"]) for a in answers}
    correct_by: Counter[str] = Counter()
    total_by: Counter[str] = Counter()
    unanswered = 0
    for item in questions:
        total_by[item.category.value] += 1
        if item.id not in given:
            unanswered += 1
            continue
        reply = given[item.id].strip()
        letters = {chr(ord("A") + i): c for i, c in enumerate(item.choices)}
        if reply.upper().rstrip(".)") in letters and len(reply.rstrip(".)")) == 1:
            reply = letters[reply.upper().rstrip(".)")]
        if normalise_answer(reply) == normalise_answer(item.answer):
            correct_by[item.category.value] += 1
    per: dict[str, dict[str, float | None]] = {}
    for c in Category:
        n_right, n = correct_by[c.value], total_by[c.value]
        per[c.value] = {"correct": n_right, "total": n, "accuracy": n_right / n if n else None}
    correct = sum(correct_by.values())
    total = sum(total_by.values())
    overall = {"correct": correct, "total": total, "accuracy": correct / total if total else None}
    return {"per_category": per, "overall": overall, "unanswered": unanswered}
