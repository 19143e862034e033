"""Embodied VQA data from assembled scenes (paper Sec. 'Embodied Visual Question Answering in Assembled
Scenes', appendix 'VQA Data Generation').

    scene = read_run("RUN")                      # or VqaScene(...), scene_from_ground_truth(gt)
    dataset = build_vqa(scene, VqaConfig(seed=0))
    write_vqa(dataset, "RUN/vqa")                # questions.jsonl, views/*.png, summary.json
    scores = evaluate_answers(dataset.items, {"q00000": "lamp", ...})
    build_dataset([scene_source("RUN"), ...], "DS", VqaConfig(sampling="walk"))   # rescene_core.vqa.build
    evaluate_dataset("DS", endpoint="http://host:8000/v1", model="...")          # rescene_core.vqa.evaluate

docs/vqa.md describes the templates, filters and files.
"""

from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.dataset import (
    VqaDataset,
    build_vqa,
    evaluate_answers,
    normalise_answer,
    read_questions,
    vqa_for_run,
    write_vqa,
)
from rescene_core.vqa.generate import Category, Filter, GeneratedQuestions, VqaItem, generate_questions, wall_direction
from rescene_core.vqa.items import TABLE4_TASKS, TaskType
from rescene_core.vqa.render import Viewpoint, look_at, make_renderer, sample_viewpoints
from rescene_core.vqa.scene import (
    VqaInputError,
    VqaObject,
    VqaScene,
    read_run,
    scene_from_ground_truth,
    scene_from_synth_layout,
)

__all__ = [
    "Category",
    "Filter",
    "GeneratedQuestions",
    "TABLE4_TASKS",
    "TaskType",
    "Viewpoint",
    "VqaConfig",
    "VqaDataset",
    "VqaInputError",
    "VqaItem",
    "VqaObject",
    "VqaScene",
    "build_vqa",
    "evaluate_answers",
    "generate_questions",
    "look_at",
    "make_renderer",
    "normalise_answer",
    "read_questions",
    "read_run",
    "sample_viewpoints",
    "scene_from_ground_truth",
    "scene_from_synth_layout",
    "vqa_for_run",
    "wall_direction",
    "write_vqa",
]
