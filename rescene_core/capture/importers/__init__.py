"""Importers: real captures into the capture format (``rescene import FORMAT SRC OUT.zarr``).

Each format module reads its layout into ``SourceFrames``; ``writer.finish_import`` aligns gravity, makes
instance masks when asked (``--segment geometric``), fuses instance point clouds from depth and writes a
validated capture with an import report. docs/importing.md describes the layouts.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from rescene_core.capture.importers.common import ImportInputError, ImportOptions
from rescene_core.capture.importers.writer import report_path

FORMATS: dict[str, str] = {
    "rgbd": "rescene_core.capture.importers.rgbd:import_rgbd",
    "scannet": "rescene_core.capture.importers.scannet:import_scannet",
    "nerfstudio": "rescene_core.capture.importers.nerfstudio:import_nerfstudio",
    "panoptic": "rescene_core.capture.importers.panoptic:import_panoptic",
}
"""Format name -> importer function ``(src, out, opts, **configs) -> report``."""


def import_capture(
    fmt: str, src: str | Path, out: str | Path, opts: ImportOptions | None = None, **configs: Any
) -> dict[str, Any]:
    """Import ``src`` (layout ``fmt``) into a capture at ``out``; returns the import report."""
    if fmt not in FORMATS:
        raise ImportInputError(f"unknown import format {fmt!r}; choose one of {', '.join(FORMATS)}")
    module, name = FORMATS[fmt].split(":")
    fn = getattr(importlib.import_module(module), name)
    return fn(src, out, opts or ImportOptions(), **configs)


__all__ = ["FORMATS", "ImportInputError", "ImportOptions", "import_capture", "report_path"]
