"""Panoptic outputs: frames in any importer's layout plus a folder of per-frame instance-id PNGs and a
``labels.json`` - what a panoptic model (PanSt3R, Mask2Former, SAM with tracking) writes, so any
segmenter can feed ReScene.

    SRC/<an rgbd, scannet or nerfstudio layout>
    SRC/instances/<frame name>.png   uint16 (or uint8, or RGB-encoded R + 256 G + 65536 B) instance ids, 0 = none
    SRC/labels.json                  {"7": "chair", ...} or [{"id": 7, "label": "chair", "structural": false}, ...]

Instance PNGs are named like the frames' colour images (stem). Ids must be consistent across frames.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.capture.importers.common import (
    ImportInputError,
    ImportOptions,
    mask_id_counts,
    require_dir,
    require_file,
)
from rescene_core.capture.importers.nerfstudio import read_nerfstudio
from rescene_core.capture.importers.rgbd import read_rgbd
from rescene_core.capture.importers.scannet import read_scannet
from rescene_core.capture.importers.writer import finish_import, labels_from_json


def detect_base(src: Path) -> str:
    """The layout of the frames in ``src``: 'nerfstudio', 'scannet' or 'rgbd'."""
    if (src / "transforms.json").is_file():
        return "nerfstudio"
    if (src / "pose").is_dir() and (src / "color").is_dir():
        return "scannet"
    if (src / "poses.txt").is_file():
        return "rgbd"
    raise ImportInputError(
        f"{src}: cannot tell the layout of the frames (no transforms.json, pose/ + color/, or poses.txt); "
        "pass --base rgbd|scannet|nerfstudio"
    )


def import_panoptic(
    src: str | Path,
    out: str | Path,
    opts: ImportOptions | None = None,
    masks: str | Path | None = None,
    labels: str | Path | None = None,
    base: str | None = None,
    **configs: Any,
) -> dict[str, Any]:
    """Import frames plus per-frame instance PNGs and labels into a capture at ``out``; returns the report."""

    opts = opts or ImportOptions()
    started = time.perf_counter()
    src = Path(src)
    require_dir(src, "source", "pass the folder with the frames, instances/ and labels.json")
    mask_dir = require_dir(Path(masks) if masks else src / "instances", "instance PNG", "pass --masks DIR")
    labels_file = require_file(
        Path(labels) if labels else src / "labels.json", "labels.json", "write {id: label} for the instance ids"
    )
    try:
        table = labels_from_json(json.loads(labels_file.read_text()), labels_file)
    except json.JSONDecodeError as err:
        raise ImportInputError(f"{labels_file}: not valid JSON ({err})") from err
    base = base or detect_base(src)
    if base == "rgbd":
        frames = read_rgbd(src, opts, mask_dir=mask_dir)
    elif base == "nerfstudio":
        frames = read_nerfstudio(src, opts, mask_dir=mask_dir)
    elif base == "scannet":
        frames = read_scannet(src, opts, mask_dir=mask_dir)
    else:
        raise ImportInputError(f"unknown base layout {base!r}; use rgbd, scannet or nerfstudio")
    frames.source = "panoptic"
    if frames.masks is None:
        raise ImportInputError(f"{mask_dir}: no instance masks were read; the panoptic import needs one mask per frame")
    unknown = sorted({int(i) for i in np.flatnonzero(mask_id_counts(frames.masks, mask_dir)) if i > 0} - set(table))
    if unknown:
        frames.notes.append(
            f"{len(unknown)} instance id(s) in {mask_dir} have no entry in {labels_file.name} "
            f"(first: {unknown[:5]}); they are labelled 'object'"
        )
    frames.labels = table
    frames.notes.append(f"frames read in the {base} layout")
    return finish_import(frames, out, opts, started, **configs)
