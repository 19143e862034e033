"""Per-category physical constants for the simulation exports (MJCF, USD): density and friction.

Meshes are closed shapes whose interiors count as filled (a wardrobe is a solid block to the exporter), so
``BULK_DENSITY`` is the mass of a typical object of the category divided by the volume of its closed
shape, not the density of its material: a 1.6 m^3 wardrobe of 60-80 kg is about 45 kg/m^3.
``FRICTION`` is the sliding friction coefficient of the category's usual contact surface (wood, fabric,
metal, glass) against a floor or a shelf. A label not in a table gets the ``DEFAULT_*`` value and an
entry in ``scene/export_report.json``. ``ExportConfig.physics_table`` names a JSON file
``{"density": {label: kg/m^3}, "friction": {label: mu}}`` whose entries replace these.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

BULK_DENSITY: dict[str, float] = {
    "bed": 60.0,
    "nightstand": 120.0,
    "wardrobe": 45.0,
    "cabinet": 110.0,
    "desk": 80.0,
    "chair": 280.0,
    "dining table": 120.0,
    "sofa": 70.0,
    "bookshelf": 90.0,
    "floor lamp": 250.0,
    "table lamp": 300.0,
    "monitor": 400.0,
    "book stack": 650.0,
    "potted plant": 400.0,
    "small plant": 400.0,
    "picture": 500.0,
    "tv": 400.0,
    "wall clock": 300.0,
    "mirror": 900.0,
    "wall shelf": 300.0,
}
"""Mass per closed-shape volume by category (kg/m^3)."""

FRICTION: dict[str, float] = {
    "bed": 0.8,
    "nightstand": 0.5,
    "wardrobe": 0.5,
    "cabinet": 0.5,
    "desk": 0.5,
    "chair": 0.6,
    "dining table": 0.5,
    "sofa": 0.8,
    "bookshelf": 0.5,
    "floor lamp": 0.5,
    "table lamp": 0.5,
    "monitor": 0.5,
    "book stack": 0.6,
    "potted plant": 0.6,
    "small plant": 0.6,
    "picture": 0.5,
    "tv": 0.4,
    "wall clock": 0.4,
    "mirror": 0.3,
    "wall shelf": 0.5,
}
"""Sliding friction coefficient by category."""

DEFAULT_DENSITY = 150.0
"""Density of a category not in the table (kg/m^3)."""
DEFAULT_FRICTION = 0.5
"""Friction of a category not in the table."""
SHELL_FRICTION = 0.8
"""Sliding friction of the floor and wall slabs (MuJoCo uses the larger of two touching geoms' values)."""


@dataclass(frozen=True)
class PhysicsTable:
    """Density (kg/m^3) and friction by lower-case label, with the defaults for unknown labels."""

    density: dict[str, float] = field(default_factory=lambda: dict(BULK_DENSITY))
    friction: dict[str, float] = field(default_factory=lambda: dict(FRICTION))
    default_density: float = DEFAULT_DENSITY
    default_friction: float = DEFAULT_FRICTION

    def lookup(self, label: str) -> tuple[float, float, list[str]]:
        """(density, friction, guesses): guesses name each default used for ``label``."""
        key = label.strip().lower()
        guesses = []
        density = self.density.get(key)
        if density is None:
            density = self.default_density
            guesses.append(f"density: no entry for {label!r}, default {density} kg/m^3")
        friction = self.friction.get(key)
        if friction is None:
            friction = self.default_friction
            guesses.append(f"friction: no entry for {label!r}, default {friction}")
        return float(density), float(friction), guesses


def load_physics_table(path: str | Path | None) -> PhysicsTable:
    """The built-in table, with the entries of the JSON file at ``path`` (when given) replacing its own."""
    table = PhysicsTable()
    if path is None:
        return table
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ValueError(f"{path}: cannot read the physics table ({err}); fix the JSON or unset physics_table") from err
    for key in ("density", "friction"):
        values = doc.get(key, {})
        if not isinstance(values, dict) or not all(isinstance(v, int | float) and v > 0 for v in values.values()):
            raise ValueError(f"{path}: field {key!r} must map labels to positive numbers")
        getattr(table, key).update({str(k).lower(): float(v) for k, v in values.items()})
    return table
