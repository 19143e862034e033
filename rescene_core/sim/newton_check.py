"""The physics check in a second engine: Newton (NVIDIA's Warp-based simulator, on the CPU here) loads
``scene/scene.usda`` through its UsdPhysics importer, the file Isaac Sim users open, and settles it.

The same figures as the MuJoCo check (``rescene_core/sim/check.py``: stable, fell through, escaped, t=0
penetration), so the two can be compared object by object. Only the USD is read: rigid bodies are the prims
with ``PhysicsRigidBodyAPI`` (free), static colliders are the shell and the mounted objects (fixed).

Solver: XPBD, Newton's default rigid-body solver, with the time step the stage declares (Newton reads
``newton:timeStepsPerSecond`` or ``physxScene:timeStepsPerSecond`` and falls back to 1000 Hz; ReScene's
USD declares neither, so 1 ms). Contacts come from Newton's ``CollisionPipeline`` (convex pieces as
``CONVEX_MESH``, the shell as triangle meshes). XPBD's iteration count is ``NEWTON_ITERATIONS``; at a
4 ms step XPBD lets a 200 kg island slide off its counter where it stays put at 1 ms, which is why the
step is the stage's and not the MJCF's 2 ms.

The first check in a fresh environment compiles Warp's kernels (about a minute on 2 cores, cached in
``~/.cache/warp``); ``make setup`` warms that cache so runs and tests do not pay it.

Where the engines disagree on an object (stable in one, not in the other), ``compare`` names it with
what the two files declare differently for it: collision pieces, mass, friction, free or fixed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rescene_core.config import SimcheckConfig
from rescene_core.exported_scene import ExportedScene
from rescene_core.io import read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import RoomShell
from rescene_core.sim.check import SimcheckResult, classify, room_shake, summarise

OBJECTS_ROOT = "/World/Objects/"
PENETRATION_NOTED_M = 0.002  # a t=0 overlap deeper than this is named as a reason two engines disagree
NEWTON_ITERATIONS = 8
"""XPBD iterations per step. At its default of 2, contact jitter between a cabinet and the potted plant on it
walked the plant 29 cm off in 2 s where MuJoCo keeps it; at 8 it stays. More iterations also project a t=0
overlap out within one step, so the push becomes more velocity: the exporter cuts overlaps from 0.5 mm."""


class NewtonUnavailable(RuntimeError):
    """Newton (the ``newton`` extra) is not installed."""


def _import_newton():
    try:
        import warp as wp

        wp.config.log_level = wp.LOG_WARNING  # before Newton initialises Warp: no banner, no per-kernel lines
        import newton
    except ImportError as err:
        raise NewtonUnavailable(
            f"the Newton engine needs the `newton` extra ({err.name} is missing): "
            "pip install 'rescene[newton]' (make setup installs it)"
        ) from err
    return newton, wp


def _node_of(path: str) -> str | None:
    """The object node of a USD prim path under /World/Objects, None for anything else (the shell)."""
    if not path.startswith(OBJECTS_ROOT):
        return None
    return path[len(OBJECTS_ROOT) :].split("/")[0]


def _rotate(q_xyzw: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` [N, 3] rotated by unit quaternions ``q_xyzw`` [N, 4] (Warp's order: x, y, z, w)."""
    u, w = q_xyzw[:, :3], q_xyzw[:, 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _centres(body_q: np.ndarray, body_com: np.ndarray) -> np.ndarray:
    """World centres of mass [N, 3] from Warp body transforms [N, 7] (p, q xyzw) and local centres [N, 3]."""
    return body_q[:, :3] + _rotate(body_q[:, 3:], body_com)


def _contact_depths(model, state, contacts) -> np.ndarray:
    """Per shape the deepest penetration (m, >= 0) among the current contacts."""
    depth = np.zeros(model.shape_count)
    n = int(contacts.rigid_contact_count.numpy()[0])
    if n == 0:
        return depth
    s0 = contacts.rigid_contact_shape0.numpy()[:n]
    s1 = contacts.rigid_contact_shape1.numpy()[:n]
    keep = (s0 >= 0) & (s1 >= 0)
    s0, s1 = s0[keep], s1[keep]
    p0 = contacts.rigid_contact_point0.numpy()[:n][keep]
    p1 = contacts.rigid_contact_point1.numpy()[:n][keep]
    normal = contacts.rigid_contact_normal.numpy()[:n][keep]
    margin = contacts.rigid_contact_margin0.numpy()[:n][keep] + contacts.rigid_contact_margin1.numpy()[:n][keep]
    shape_body = model.shape_body.numpy()
    body_q = state.body_q.numpy()

    def world(points: np.ndarray, shapes: np.ndarray) -> np.ndarray:
        bodies = shape_body[shapes]
        out = points.astype(np.float64).copy()
        moving = bodies >= 0
        q = body_q[bodies[moving]]
        out[moving] = q[:, :3] + _rotate(q[:, 3:], points[moving])
        return out

    gap = np.einsum("ij,ij->i", normal, world(p1, s1) - world(p0, s0)) - margin
    pen = np.clip(-gap, 0.0, None)
    np.maximum.at(depth, s0, pen)
    np.maximum.at(depth, s1, pen)
    return depth


@dataclass(frozen=True)
class NewtonModelFacts:
    """What the USD declares per object, as Newton read it: collision pieces, mass (kg; None when fixed),
    the lowest sliding friction coefficient of its colliders."""

    pieces: dict[str, int]
    mass: dict[str, float | None]
    friction: dict[str, float]
    timestep: float


def newton_simcheck(usd: str | Path, shell: RoomShell | None, config: SimcheckConfig) -> tuple[SimcheckResult, dict]:
    """Load ``usd`` in Newton, settle it ``config.seconds`` (shaken like the MuJoCo check with
    ``config.shake``), classify every object. Returns the result (its ``config`` records the engine, the
    solver, the time step and the model facts) and the before/after centres per node."""
    newton, wp = _import_newton()
    started = time.perf_counter()
    builder = newton.ModelBuilder()
    info = builder.add_usd(str(usd))
    model = builder.finalize(device="cpu")
    dt = float(info.get("physics_dt") or 0.001)

    labels = list(model.body_label)
    shape_body = model.shape_body.numpy()
    shape_flags = model.shape_flags.numpy()
    collide = int(newton.ShapeFlags.COLLIDE_SHAPES)
    body_node = [_node_of(label) for label in labels]
    pieces: dict[str, int] = {}
    friction: dict[str, float] = {}
    fixed_nodes: dict[str, None] = {}  # in the order the importer made them, each once
    shape_mu = model.shape_material_mu.numpy()
    for label, body, flags, mu in zip(model.shape_label, shape_body, shape_flags, shape_mu, strict=True):
        node = _node_of(label)
        if node is None or not flags & collide:
            continue
        pieces[node] = pieces.get(node, 0) + 1
        friction[node] = round(min(friction.get(node, np.inf), float(mu)), 4)
        if body < 0:
            fixed_nodes[node] = None
    masses = model.body_mass.numpy()
    mass: dict[str, float | None] = {n: None for n in fixed_nodes}
    mass.update({n: float(m) for n, m in zip(body_node, masses, strict=True) if n is not None})

    state0, state1, control = model.state(), model.state(), model.control()
    newton.eval_fk(model, model.joint_q, model.joint_qd, state0)
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    pipeline.collide(state0, contacts)
    shape_depth = _contact_depths(model, state0, contacts)
    depth: dict[str, float] = {}
    for label, d in zip(model.shape_label, shape_depth, strict=True):
        node = _node_of(label)
        if node is not None:
            depth[node] = max(depth.get(node, 0.0), float(d))

    com = model.body_com.numpy()
    q_start = state0.body_q.numpy().copy()
    start = _centres(q_start, com)
    solver = newton.solvers.SolverXPBD(model, iterations=NEWTON_ITERATIONS)
    gravity = model.gravity.numpy().copy()
    shake = room_shake(config)
    steps = int(round(config.seconds / dt))
    for k in range(steps):
        if config.shake:
            g = gravity.copy()
            g[:, :2] = gravity[:, :2] - shake(k * dt)
            model.gravity.assign(g)
        state0.clear_forces()
        pipeline.collide(state0, contacts)
        solver.step(state0, state1, control, contacts, dt)
        state0, state1 = state1, state0
    q_end = state0.body_q.numpy()
    if not np.isfinite(q_end).all():
        raise RuntimeError(f"{usd}: the Newton simulation diverged (non-finite state)")
    end = _centres(q_end, com)

    kinds: dict[str, str] = {}
    before: dict[str, np.ndarray] = {}
    after: dict[str, np.ndarray] = {}
    quat0: dict[str, np.ndarray] = {}
    quat1: dict[str, np.ndarray] = {}
    for b, node in enumerate(body_node):
        if node is None:
            continue
        kinds[node] = "free"
        before[node], after[node] = start[b], end[b]
        quat0[node], quat1[node] = q_start[b, 3:], q_end[b, 3:]
    still = np.array([0.0, 0.0, 0.0, 1.0])
    for node in fixed_nodes:
        kinds[node] = "fixed"
        before[node] = after[node] = np.zeros(3)
        quat0[node] = quat1[node] = still
    objects = classify(kinds, before, after, quat0, quat1, depth, shell, config)
    summary = summarise(objects, config, time.perf_counter() - started)
    facts = NewtonModelFacts(pieces, mass, friction, dt)
    record = config.model_dump(mode="json") | {
        "engine": "newton",
        "newton_version": newton.__version__,
        "solver": f"XPBD, {NEWTON_ITERATIONS} iterations",
        "timestep": dt,
        "pieces": facts.pieces,
        "mass": facts.mass,
        "friction": facts.friction,
    }
    result = SimcheckResult(tuple(objects), summary, None, record)
    motion = {node: (before[node], after[node]) for node in kinds if kinds[node] == "free"}
    return result, motion


def _mujoco_facts(mjcf: Path) -> tuple[dict[str, int], dict[str, float | None], dict[str, float]]:
    """Collision pieces (geoms that collide), mass (None when fixed) and the lowest sliding friction of
    its colliding geoms per body of the MJCF."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(mjcf))
    free = {int(model.jnt_bodyid[j]) for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE}
    pieces: dict[str, int] = {}
    friction: dict[str, float] = {}
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if b == 0 or not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        name = model.body(b).name
        pieces[name] = pieces.get(name, 0) + 1
        friction[name] = round(min(friction.get(name, np.inf), float(model.geom_friction[g][0])), 4)
    mass = {model.body(b).name: (float(model.body_mass[b]) if b in free else None) for b in range(1, model.nbody)}
    return pieces, mass, friction


def compare(mujoco_check: dict[str, Any], newton_check: dict[str, Any], mjcf: Path) -> list[dict[str, Any]]:
    """The objects on which the two engines disagree (stable in one, not the other), each with both drifts
    and what the MJCF and the USD declare differently for it; where they declare the same, the reason
    given is the engines' contact models."""
    pieces_mj, mass_mj, friction_mj = _mujoco_facts(mjcf)
    facts = newton_check["config"]
    pieces_nt, mass_nt, friction_nt = facts["pieces"], facts["mass"], facts.get("friction", {})
    by_node = {o["node"]: o for o in mujoco_check["objects"]}
    out = []
    for o in newton_check["objects"]:
        m = by_node.get(o["node"])
        if m is None or o["kind"] != "free" and m["kind"] != "free" or m["stable"] == o["stable"]:
            continue
        node = o["node"]
        reasons = []
        if m["kind"] != o["kind"]:
            reasons.append(f"free/fixed: MJCF {m['kind']}, USD {o['kind']}")
        if pieces_mj.get(node) != pieces_nt.get(node):
            reasons.append(f"collision pieces: MJCF {pieces_mj.get(node)}, USD {pieces_nt.get(node)}")
        a, b = mass_mj.get(node), mass_nt.get(node)
        if a is not None and b is not None and abs(a - b) > 1e-3 * max(a, b):
            reasons.append(f"mass: MJCF {a:.3f} kg, USD {b:.3f} kg")
        f_mj, f_nt = friction_mj.get(node), friction_nt.get(node)
        if f_mj is not None and f_nt is not None and abs(f_mj - f_nt) > 1e-3:
            reasons.append(f"friction: MJCF {f_mj:.2f}, USD as Newton read it {f_nt:.2f}")
        depth = max(m["penetration_t0"], o["penetration_t0"])
        if depth > PENETRATION_NOTED_M:
            reasons.append(
                f"penetrating {depth * 1000:.1f} mm at t=0: XPBD projects it out and the push becomes velocity, "
                "MuJoCo's soft contact pushes it out slowly"
            )
        if not reasons:
            reasons.append("same declaration in both files: the engines' contact models differ (MuJoCo soft, XPBD)")
        out.append(
            {
                "node": node,
                "stable_mujoco": m["stable"],
                "stable_newton": o["stable"],
                "drift_mujoco": m["translation"],
                "drift_newton": o["translation"],
                "reasons": reasons,
            }
        )
    return out


def newton_simcheck_run(run_dir: str | Path, config: SimcheckConfig | None = None) -> dict[str, Any]:
    """The Newton check on a run directory: reads scene/scene.usda (and scene/scene.json for the room),
    writes sim/simcheck-newton.json (the MuJoCo check's layout plus ``engine`` and, when
    sim/simcheck.json exists, ``disagreements`` with it). Returns what it wrote."""
    run = RunPaths(run_dir)
    config = config or SimcheckConfig()
    usd = run.scene_usda if run.scene_usda.exists() else run.scene_usdc
    if not usd.exists():
        raise FileNotFoundError(
            f"{run.scene_usda} does not exist; export the scene first (`rescene export {run_dir}` or `rescene run`)"
        )
    shell = ExportedScene.read(run.scene_json).shell if run.scene_json.exists() else None
    result, _ = newton_simcheck(usd, shell, config)
    record = result.to_json() | {"engine": "newton"}
    if run.simcheck.exists() and run.scene_mjcf.exists():
        mujoco_check = read_json(run.simcheck)
        if mujoco_check.get("config", {}).get("shake", False) == config.shake:
            record["disagreements"] = compare(mujoco_check, record, run.scene_mjcf)
    write_json_atomic(run.simcheck_newton, record)
    return record
