"""The whole run's configuration (``RunConfig``, one section per stage), ``--set`` overrides and YAML loading."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import yaml
from pydantic import Field

from rescene_core.config.attachment import AttachmentConfig
from rescene_core.config.base import _Section
from rescene_core.config.capture import HierViewConfig, KeyFrameConfig, ShellConfig
from rescene_core.config.objects import AssetConfig, RegistrationConfig
from rescene_core.config.outputs import ExportConfig, SimcheckConfig, VqaConfig
from rescene_core.config.scenegraph import SceneGraphConfig


class RunConfig(_Section):
    """Everything one run of the flow needs besides the capture and the run directory."""

    shell: ShellConfig = Field(default_factory=ShellConfig)
    hierview: HierViewConfig = Field(default_factory=HierViewConfig)
    keyframes: KeyFrameConfig = Field(default_factory=KeyFrameConfig)
    assets: AssetConfig = Field(default_factory=AssetConfig)
    registration: RegistrationConfig = Field(default_factory=RegistrationConfig)
    scenegraph: SceneGraphConfig = Field(default_factory=SceneGraphConfig)
    attachment: AttachmentConfig = Field(default_factory=AttachmentConfig)
    export: ExportConfig = Field(default_factory=ExportConfig)
    sim: SimcheckConfig = Field(default_factory=SimcheckConfig)
    vqa: VqaConfig = Field(default_factory=VqaConfig)

    def section_hash(self, name: str) -> str:
        """Stable hash of one section's values (for cache keys)."""
        section = getattr(self, name)
        blob = json.dumps(section.model_dump(mode="json"), sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def with_overrides(self, assignments: list[str]) -> RunConfig:
        """Apply ``section.field=value`` or ``section.sub.field=value`` overrides (values parsed as YAML
        scalars), e.g. ``scenegraph.vlm.base_url=http://gpu:8000/v1`` or ``assets.lift.resolution=48``."""
        data = self.model_dump(mode="json")
        for item in assignments:
            key, sep, raw = item.partition("=")
            parts = key.strip().split(".")
            if not sep or len(parts) < 2 or not all(parts):
                raise ValueError(f"--set expects section.field=value (or section.sub.field=value), got {item!r}")
            node = data
            for depth, part in enumerate(parts[:-1]):
                child = node.get(part)
                if not isinstance(child, dict):
                    where = ".".join(parts[:depth]) or "sections"
                    choices = ", ".join(sorted(k for k, v in node.items() if isinstance(v, dict)))
                    raise ValueError(f"--set {key}: {part!r} is not one of the {where} ({choices})")
                node = child
            name = parts[-1]
            if isinstance(node.get(name), dict):
                fields = ", ".join(sorted(node[name]))
                raise ValueError(f"--set {key}: {key} is a group of settings; set one of them ({fields})")
            if name not in node:
                group = ".".join(parts[:-1])
                raise ValueError(f"--set {key}: {group} has no setting {name!r} (settings: {', '.join(sorted(node))})")
            node[name] = yaml.safe_load(raw)
        return RunConfig.model_validate(data)


def load_config(path: str | Path | None = None, overrides: list[str] | None = None) -> RunConfig:
    """Read a YAML config file (missing fields take the defaults) and apply ``--set`` overrides."""
    data: dict[str, Any] = {}
    if path is not None:
        loaded = yaml.safe_load(Path(path).read_text())
        if loaded is not None and not isinstance(loaded, dict):
            raise ValueError(f"{path}: expected a mapping of sections, got {type(loaded).__name__}")
        data = loaded or {}
    config = RunConfig.model_validate(data)
    return config.with_overrides(overrides or [])
