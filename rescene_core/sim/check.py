"""The physics check: load ``scene/mjcf/scene.xml`` in MuJoCo, measure the deepest penetration at t = 0,
step ``seconds`` of simulated time under gravity, then measure per object how far it moved.

An object is *stable* when its centre of mass moved less than ``stable_translation`` and it turned less
than ``stable_rotation_deg``. It *fell through* when its centre of mass ends below the floor, and
*escaped* when it ends outside the floor polygon (grown by ``escape_margin``) or above the walls.
Only free bodies can move; mounted (fixed) bodies are listed and count as neither stable nor unstable.

``shake``: the room (floor, walls and mounted objects) is shaken horizontally during the first
``shake_seconds``. In the room's frame that is exactly a horizontal term -a(t) added to gravity, which
is how it is simulated: a(t) is a sum of sinusoids with seeded random phases and directions, peak
``shake_accel``. MuJoCo is deterministic, so the result depends only on the model, the config and the
seed.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from shapely.geometry import Point, Polygon

from rescene_core.config import SimcheckConfig
from rescene_core.exported_scene import ExportedScene
from rescene_core.geometry.room import floor_height
from rescene_core.io import write_bytes_atomic, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import RoomShell


@dataclass(frozen=True)
class ObjectDrift:
    """One body after the check. translation (m), rotation (deg), penetration_t0 (m, deepest contact)."""

    node: str
    kind: str
    translation: float
    rotation_deg: float
    penetration_t0: float
    stable: bool
    fell_through: bool
    escaped: bool


@dataclass(frozen=True)
class SimcheckSummary:
    """The figures of one check (they go to eval/metrics.json). Counts of bodies; ``stable_fraction`` over
    the free ones (1.0 when there are none); penetrations at t=0, drifts in m, rotations in deg;
    ``seconds_simulated``: simulated time; ``seconds``: wall time of the check."""

    objects: int
    free: int
    fixed: int
    stable: int
    stable_fraction: float
    fell_through: int
    escaped: int
    penetration_t0_max: float
    penetration_t0_mean: float
    drift_max: float
    rotation_max_deg: float
    seconds_simulated: float
    shake: bool
    seconds: float

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SimcheckSummary:
        return cls(**{f: d[f] for f in cls.__dataclass_fields__})

    def numbers(self) -> dict[str, int | float]:
        """The numeric figures (flags left out), for run-log metrics and task references."""
        return {k: v for k, v in self.to_json().items() if isinstance(v, int | float) and not isinstance(v, bool)}


@dataclass(frozen=True)
class SimcheckResult:
    """The whole check; ``summary`` holds the figures that go to eval/metrics.json."""

    objects: tuple[ObjectDrift, ...]
    summary: SimcheckSummary
    deepest_pair: tuple[str, str] | None = None
    config: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "format": "rescene-simcheck",
            "version": 1,
            "summary": self.summary.to_json(),
            "deepest_pair_t0": list(self.deepest_pair) if self.deepest_pair else None,
            "unstable": [o.node for o in self.objects if o.kind == "free" and not o.stable],
            "objects": [asdict(o) for o in self.objects],
            "config": self.config,
        }


def _body_of_geom(model) -> np.ndarray:
    return np.asarray(model.geom_bodyid)


def penetrations(model, data) -> tuple[dict[int, float], tuple[int, int] | None, float]:
    """Per body id the deepest penetration (m) of its contacts now, the deepest pair of geoms, its depth."""
    bodies = _body_of_geom(model)
    depth: dict[int, float] = {}
    worst, worst_pair = 0.0, None
    for k in range(data.ncon):
        c = data.contact[k]
        d = -float(c.dist)
        if d <= 0:
            continue
        for g in (c.geom1, c.geom2):
            b = int(bodies[g])
            depth[b] = max(depth.get(b, 0.0), d)
        if d > worst:
            worst, worst_pair = d, (int(c.geom1), int(c.geom2))
    return depth, worst_pair, worst


def room_shake(config: SimcheckConfig) -> Callable[[float], np.ndarray]:
    """The room's horizontal acceleration [2] (m/s^2) at time t (s) of ``config``'s shake: a sum of
    sinusoids with seeded directions and phases under a half-sine envelope, zero after ``shake_seconds``.
    An engine simulates it as ``gravity[:2] - shake(t)`` in the room's frame (the module doc)."""
    rng = np.random.default_rng(config.seed)
    angles = rng.uniform(0, 2 * np.pi, size=len(config.shake_hz))
    phases = rng.uniform(0, 2 * np.pi, size=len(config.shake_hz))
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    omegas = 2 * np.pi * np.asarray(config.shake_hz, np.float64)

    def shake(t: float) -> np.ndarray:
        if t >= config.shake_seconds:
            return np.zeros(2)
        envelope = np.sin(np.pi * t / config.shake_seconds)
        amp = config.shake_accel / len(omegas) * envelope * np.sin(omegas * t + phases)
        return (amp[:, None] * dirs).sum(axis=0)

    return shake


def classify(
    kinds: dict[str, str],
    start: dict[str, np.ndarray],
    end: dict[str, np.ndarray],
    start_quat: dict[str, np.ndarray],
    end_quat: dict[str, np.ndarray],
    depth_t0: dict[str, float],
    shell: RoomShell | None,
    config: SimcheckConfig,
) -> list[ObjectDrift]:
    """Each body's drift and verdict, whatever engine moved it. Per node: ``kinds`` "free" or "fixed",
    centre of mass before and after ([3], m, world), orientation before and after (unit quaternions [4],
    any one convention for both), deepest contact at t=0 (m). The rules are the module doc's."""
    floor_z, top_z, room = 0.0, np.inf, None
    if shell is not None:
        floor_z = floor_height(shell)
        top_z = floor_z + (shell.ceiling_height or 2.5) + 0.5
        room = Polygon(shell.floor_polygon).buffer(config.escape_margin)
    objects = []
    for name, kind in kinds.items():
        moved = float(np.linalg.norm(end[name] - start[name]))
        dot = abs(float(np.dot(end_quat[name], start_quat[name])))
        turned = float(np.degrees(2 * np.arccos(min(1.0, dot))))
        at = end[name]
        fell = bool(at[2] < floor_z)
        escaped = bool((room is not None and not room.contains(Point(at[0], at[1]))) or at[2] > top_z)
        stable = moved < config.stable_translation and turned < config.stable_rotation_deg and not fell
        objects.append(
            ObjectDrift(
                name, kind, round(moved, 6), round(turned, 4), round(depth_t0.get(name, 0.0), 6), stable, fell, escaped
            )
        )
    return objects


def summarise(objects: list[ObjectDrift], config: SimcheckConfig, seconds: float) -> SimcheckSummary:
    """The summary of classified bodies; ``seconds``: wall time of the check."""
    free = [o for o in objects if o.kind == "free"]
    pens = [o.penetration_t0 for o in objects]
    return SimcheckSummary(
        objects=len(objects),
        free=len(free),
        fixed=len(objects) - len(free),
        stable=sum(o.stable for o in free),
        stable_fraction=round(sum(o.stable for o in free) / len(free), 4) if free else 1.0,
        fell_through=sum(o.fell_through for o in free),
        escaped=sum(o.escaped for o in free),
        penetration_t0_max=round(max(pens, default=0.0), 6),
        penetration_t0_mean=round(float(np.mean(pens)) if pens else 0.0, 6),
        drift_max=round(max((o.translation for o in free), default=0.0), 6),
        rotation_max_deg=round(max((o.rotation_deg for o in free), default=0.0), 4),
        seconds_simulated=config.seconds,
        shake=config.shake,
        seconds=round(seconds, 3),
    )


def simcheck(mjcf: str | Path, shell: RoomShell | None, config: SimcheckConfig) -> tuple[SimcheckResult, dict]:
    """Run the check on an MJCF written by rescene_core/export/mjcf.py. Returns the result and the
    before/after poses {node: (centre before [3], centre after [3])} for the picture."""
    import mujoco

    started = time.perf_counter()
    model = mujoco.MjModel.from_xml_path(str(mjcf))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    depth_t0, pair, _ = penetrations(model, data)
    free_bodies = {
        int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    }
    names = {b: model.body(b).name for b in range(1, model.nbody)}
    start_pos = {b: data.xipos[b].copy() for b in names}
    start_quat = {b: data.xquat[b].copy() for b in names}
    gravity = model.opt.gravity.copy()
    steps = int(round(config.seconds / model.opt.timestep))
    shake = room_shake(config)
    for k in range(steps):
        if config.shake:
            model.opt.gravity[:2] = gravity[:2] - shake(k * model.opt.timestep)
        mujoco.mj_step(model, data)
    model.opt.gravity[:] = gravity
    if not np.isfinite(data.qpos).all():
        raise RuntimeError(f"{mjcf}: the simulation diverged (non-finite state)")

    motion_end = {b: data.xipos[b].copy() for b in names}
    end_quat = {b: data.xquat[b].copy() for b in names}
    objects = classify(
        {names[b]: "free" if b in free_bodies else "fixed" for b in names},
        {names[b]: start_pos[b] for b in names},
        {names[b]: motion_end[b] for b in names},
        {names[b]: start_quat[b] for b in names},
        {names[b]: end_quat[b] for b in names},
        {names[b]: depth_t0.get(b, 0.0) for b in names},
        shell,
        config,
    )
    summary = summarise(objects, config, time.perf_counter() - started)
    deepest: tuple[str, str] | None = None
    if pair is not None:
        first, second = (str(model.body(int(model.geom_bodyid[g])).name or "world") for g in pair)
        deepest = (first, second)
    result = SimcheckResult(tuple(objects), summary, deepest, config.model_dump(mode="json"))
    motion = {names[b]: (start_pos[b], motion_end[b]) for b in names}
    return result, motion


def draw_before_after(path: Path, result: SimcheckResult, motion: dict, shell: RoomShell | None) -> Path:
    """A plan (top) and an elevation (side) of every body's centre before (hollow) and after (filled),
    unstable objects in red with their names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    by_node = {o.node: o for o in result.objects}
    for ax, (i, j), title in ((axes[0], (0, 1), "plan (x, y)"), (axes[1], (0, 2), "elevation (x, z)")):
        if shell is not None and i == 0 and j == 1:
            poly = np.asarray(shell.floor_polygon + (shell.floor_polygon[0],))
            ax.plot(poly[:, 0], poly[:, 1], color="0.4", lw=1)
        for node, (before, after) in motion.items():
            o = by_node[node]
            colour = "0.6" if o.kind == "fixed" else ("tab:green" if o.stable else "tab:red")
            ax.scatter(before[i], before[j], s=40, facecolors="none", edgecolors=colour)
            ax.scatter(after[i], after[j], s=18, color=colour)
            ax.plot([before[i], after[i]], [before[j], after[j]], color=colour, lw=0.8)
            if o.kind == "free" and not o.stable:
                ax.annotate(node, (after[i], after[j]), fontsize=7, color="tab:red")
        ax.set_title(title)
        ax.set_aspect("equal")
    s = result.summary
    fig.suptitle(
        f"after {s.seconds_simulated} s{' with shake' if s.shake else ''}: {s.stable}/{s.free} free "
        f"objects stable; hollow = before, filled = after; grey = mounted"
    )
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=110)
    plt.close(fig)
    return write_bytes_atomic(path, png.getvalue())


def simcheck_run(run_dir: str | Path, config: SimcheckConfig | None = None) -> SimcheckResult:
    """The check on a run directory: reads scene/mjcf/scene.xml and scene/scene.json (for the room), writes
    sim/simcheck.json and sim/before_after.png."""
    run = RunPaths(run_dir)
    config = config or SimcheckConfig()
    mjcf = run.scene_mjcf
    if not mjcf.exists():
        raise FileNotFoundError(
            f"{mjcf} does not exist; export the scene first (`rescene export {run_dir}` or `rescene run`)"
        )
    shell = ExportedScene.read(run.scene_json).shell if run.scene_json.exists() else None
    result, motion = simcheck(mjcf, shell, config)
    write_json_atomic(run.simcheck, result.to_json())
    draw_before_after(run.sim_picture, result, motion, shell)
    return result
