"""A VQA data set over many scenes, split by scene, in the formats trainers and evaluators read.

    sources = [scene_source("RUN"), scene_source("room.zarr"), scene_source("synth:standard:3")]
    card = build_dataset(sources, "DS", VqaConfig(sampling="walk", per_category=60), test_ratio=3 / 13)

A source is an assembled run directory (``read_run``), a capture with ground truth (``*.zarr``: its
``gt/`` group through ``scene_from_ground_truth``), or ``synth:PRESET:SEED`` (the ground-truth layout of
that synthetic capture without rendering its frames, ``scene_from_synth_layout``).

Layout of DS (all files written atomically):

- ``scenes/<scene>/{questions.jsonl, summary.json, views/*.png}``: each scene as ``write_vqa`` writes it;
- ``train.jsonl``, ``test.jsonl``: one flat record per question (``RECORD_FIELDS``); ``image`` is relative to
  DS or null; ``viewpoint`` and ``provenance`` are JSON strings so every line has the same schema;
- ``sft/train.jsonl``, ``sft/test.jsonl``: the conversation format of LLaVA / ShareGPT-style SFT trainers,
  ``{"id", "images": [path], "messages": [{"role": "user", "content": "<image>\\n..."},
  {"role": "assistant", "content": "B. lamp"}]}``;
- ``card.json`` and ``README.md``: the data card (counts per split, category and task type, the scenes of each
  split with the backend that produced them, the generation config, what failed).

Scenes are split, never questions: every question of a scene is in the scene's split.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture import open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.io import write_bytes_atomic, write_json_atomic
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.dataset import build_vqa, write_vqa
from rescene_core.vqa.items import TABLE4_TASKS, Category, TaskType, VqaItem
from rescene_core.vqa.scene import VqaInputError, VqaScene, read_run, scene_from_ground_truth, scene_from_synth_layout

CARD_FORMAT = "rescene-vqa-dataset"
IMAGE_TOKEN = "<image>"
"""The image placeholder of LLaVA-style conversations."""
PAPER_TEST_RATIO = 3 / 13
"""The paper's split: 10 training and 3 test scenes of 13."""

RECORD_FIELDS = (
    "id",
    "scene",
    "split",
    "category",
    "task",
    "template",
    "question",
    "choices",
    "answer",
    "answer_letter",
    "prompt",
    "image",
    "viewpoint",
    "provenance",
)


@dataclass(frozen=True)
class SceneSource:
    """Where a scene comes from: kind 'run' | 'capture' | 'synth', and the path or 'PRESET:SEED'."""

    kind: str
    ref: str

    def load(self) -> VqaScene:

        if self.kind == "run":
            return read_run(self.ref)
        if self.kind == "capture":
            capture = open_capture(self.ref)
            gt = read_ground_truth(capture)
            if gt is None:
                raise VqaInputError(f"{self.ref}: the capture has no gt/ group (ground truth); pass a run instead")
            scene = scene_from_ground_truth(gt)
            scene_id = str(capture.summary().get("scene_id") or Path(self.ref).stem)
            return VqaScene(scene.objects, scene.graph, scene.shell, scene_id=scene_id, source="ground-truth")
        preset, seed = self.ref.split(":")
        return scene_from_synth_layout(preset, int(seed))


def scene_source(text: str | Path) -> SceneSource:
    """A source from a command-line argument: 'synth:PRESET:SEED', a capture '*.zarr', else a run directory."""
    text = str(text)
    if text.startswith("synth:"):
        parts = text.split(":")
        if len(parts) != 3 or not parts[2].isdigit():
            raise VqaInputError(f"{text!r}: a synthetic source is 'synth:PRESET:SEED', e.g. synth:standard:3")
        return SceneSource("synth", f"{parts[1]}:{parts[2]}")
    path = Path(text)
    if path.suffix == ".zarr":
        return SceneSource("capture", text)
    return SceneSource("run", text)


def split_scenes(scene_ids: list[str], test_ratio: float, seed: int) -> dict[str, str]:
    """Scene id -> 'train' | 'test': a seeded permutation of the sorted ids, the first round(n * ratio) to
    test (at least one each when there are two or more scenes and 0 < ratio < 1)."""
    ids = sorted(scene_ids)
    n = len(ids)
    n_test = int(round(n * test_ratio))
    if n >= 2 and 0.0 < test_ratio < 1.0:
        n_test = min(max(n_test, 1), n - 1)
    order = [ids[i] for i in np.random.default_rng(seed).permutation(n)]
    return {sid: ("test" if k < n_test else "train") for k, sid in enumerate(order)}


def letter(k: int) -> str:
    return chr(ord("A") + k)


def prompt_of(question: str, choices: tuple[str, ...] | list[str]) -> str:
    """The text put to a model: the question, lettered choices and the answer instruction."""
    lines = [question, "Choices:"] + [f"{letter(k)}. {c}" for k, c in enumerate(choices)]
    return "\n".join(lines + ["Answer with the letter of the correct choice."])


def record_of(item: VqaItem, scene: str, split: str) -> dict[str, Any]:
    """The flat data-set record of one question (``RECORD_FIELDS``)."""
    image = None if item.viewpoint is None else f"scenes/{scene}/{item.viewpoint['image']}"
    return {
        "id": f"{scene}/{item.id}",
        "scene": scene,
        "split": split,
        "category": item.category.value,
        "task": item.task.value,
        "template": item.template,
        "question": item.question,
        "choices": list(item.choices),
        "answer": item.answer,
        "answer_letter": letter(item.choices.index(item.answer)),
        "prompt": prompt_of(item.question, item.choices),
        "image": image,
        "viewpoint": None if item.viewpoint is None else json.dumps(item.viewpoint),
        "provenance": json.dumps(item.provenance),
    }


def conversation_of(record: dict[str, Any]) -> dict[str, Any]:
    """The LLaVA / ShareGPT-style conversation of a record (one image placeholder when it has an image)."""
    user = record["prompt"] if record["image"] is None else f"{IMAGE_TOKEN}\n{record['prompt']}"
    return {
        "id": record["id"],
        "images": [] if record["image"] is None else [record["image"]],
        "messages": [
            {"role": "user", "content": user},
            {"role": "assistant", "content": f"{record['answer_letter']}. {record['answer']}"},
        ],
    }


def _jsonl(rows: list[dict[str, Any]]) -> bytes:
    return "".join(json.dumps(r) + "\n" for r in rows).encode()


def _scene_key(scene: VqaScene, source: SceneSource, taken: set[str]) -> str:
    base = scene.scene_id or Path(source.ref).name or source.kind
    key = "".join(c if c.isalnum() or c in "-_." else "_" for c in base)
    k, out = 1, key
    while out in taken:
        k, out = k + 1, f"{key}_{k}"
    return out


def build_dataset(
    sources: list[SceneSource],
    out_dir: str | Path,
    config: VqaConfig,
    test_ratio: float = PAPER_TEST_RATIO,
    split_seed: int = 0,
    progress: Callable[[int, int, str], None] | None = None,
) -> dict[str, Any]:
    """Generate every scene's questions and views (scene k uses seed ``config.seed + k``), split by scene,
    and write DS (see the module docstring). A scene that cannot be read or generated is recorded in the
    card's ``failed`` list and the others go on. ``progress(done, total, scene)`` is called after each scene.
    Returns the card."""
    out = Path(out_dir)
    done: list[tuple[str, SceneSource, VqaScene, list[VqaItem], dict[str, Any], float]] = []
    failed: list[dict[str, str]] = []
    taken: set[str] = set()
    for k, source in enumerate(sources):
        t0 = time.perf_counter()
        name = source.ref
        try:
            scene = source.load()
            name = _scene_key(scene, source, taken)
            dataset = build_vqa(scene, config.model_copy(update={"seed": config.seed + k}))
            write_vqa(dataset, out / "scenes" / name)
            taken.add(name)
            done.append((name, source, scene, dataset.items, dataset.summary, time.perf_counter() - t0))
        except (OSError, ValueError, KeyError) as err:  # VqaInputError and CaptureError are ValueErrors
            failed.append({"source": f"{source.kind}:{source.ref}", "error": f"{type(err).__name__}: {err}"})
        if progress is not None:
            progress(k + 1, len(sources), name)
    splits = split_scenes([d[0] for d in done], test_ratio, split_seed)
    records: dict[str, list[dict[str, Any]]] = {"train": [], "test": []}
    for name, _source, _scene, items, _summary, _t in done:
        records[splits[name]].extend(record_of(item, name, splits[name]) for item in items)
    for split, rows in records.items():
        write_bytes_atomic(out / f"{split}.jsonl", _jsonl(rows))
        write_bytes_atomic(out / "sft" / f"{split}.jsonl", _jsonl([conversation_of(r) for r in rows]))
    card = _card(done, failed, splits, records, config, test_ratio, split_seed)
    write_json_atomic(out / "card.json", card)
    write_bytes_atomic(out / "README.md", card_markdown(card).encode())
    return card


def _card(done, failed, splits, records, config: VqaConfig, test_ratio: float, split_seed: int) -> dict[str, Any]:
    def counts(rows: list[dict[str, Any]], key: str, names: list[str]) -> dict[str, int]:
        c = Counter(r[key] for r in rows)
        return {n: int(c.get(n, 0)) for n in names}

    cats = [c.value for c in Category]
    tasks = [t.value for t in TaskType]
    return {
        "format": CARD_FORMAT,
        "version": 1,
        "questions": {s: len(r) for s, r in records.items()},
        "per_category": {s: counts(r, "category", cats) for s, r in records.items()},
        "per_task": {s: counts(r, "task", tasks) for s, r in records.items()},
        "table4_tasks": [t.value for t in TABLE4_TASKS],
        "split": {"by": "scene", "test_ratio": test_ratio, "seed": split_seed},
        "scenes": [
            {
                "name": name,
                "split": splits[name],
                "source": f"{source.kind}:{source.ref}",
                "scene_backend": scene.source,
                "render_backend": summary["render_backend"],
                "objects": len(scene.objects),
                "views": len(summary["views"]),
                "questions": len(items),
                "skipped": summary["skipped"],
                "seconds": round(seconds, 2),
            }
            for name, source, scene, items, summary, seconds in done
        ],
        "failed": failed,
        "files": {
            "records": ["train.jsonl", "test.jsonl"],
            "sft": ["sft/train.jsonl", "sft/test.jsonl"],
            "record_fields": list(RECORD_FIELDS),
        },
        "config": config.model_dump(mode="json"),
    }


def card_markdown(card: dict[str, Any]) -> str:
    """The data card as Markdown (DS/README.md)."""
    lines = [
        "# ReScene embodied VQA data set",
        "",
        f"{card['questions']['train']} training and {card['questions']['test']} test questions from "
        f"{len(card['scenes'])} scenes, split by scene (test ratio {card['split']['test_ratio']:.3f}, seed "
        f"{card['split']['seed']}). Multiple choice; answers computed from the structured scenes.",
        "",
        "| | " + " | ".join(card["per_task"]["train"]) + " |",
        "|---|" + "---|" * len(card["per_task"]["train"]),
    ]
    for split in ("train", "test"):
        lines.append(f"| {split} | " + " | ".join(str(v) for v in card["per_task"][split].values()) + " |")
    lines += ["", "| | " + " | ".join(card["per_category"]["train"]) + " |"]
    lines.append("|---|" + "---|" * len(card["per_category"]["train"]))
    for split in ("train", "test"):
        lines.append(f"| {split} | " + " | ".join(str(v) for v in card["per_category"][split].values()) + " |")
    lines += [
        "",
        "| scene | split | scene from | renderer | objects | views | questions |",
        "|---|---|---|---|---|---|---|",
    ]
    for s in card["scenes"]:
        lines.append(
            f"| {s['name']} | {s['split']} | {s['scene_backend']} | {s['render_backend']} | {s['objects']} | "
            f"{s['views']} | {s['questions']} |"
        )
    if card["failed"]:
        lines += ["", "Failed sources:", ""] + [f"- {f['source']}: {f['error']}" for f in card["failed"]]
    lines += [
        "",
        "Files: `train.jsonl` / `test.jsonl` (flat records), `sft/*.jsonl` (conversations with an `<image>` "
        "placeholder), `scenes/<scene>/views/*.png`, `card.json` (this card with the generation config).",
        "",
    ]
    return "\n".join(lines)
