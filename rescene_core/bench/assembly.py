"""`rescene bench assembly`: the attachment solver on synthetic scenes, stage by stage (paper Table 3(c)).

Inputs per scene (preset, seed): the ground-truth layout of the synthetic generator (objects, meshes,
relations, room shell). Starting poses:
  gt-perturbed: ground-truth poses perturbed the way reconstructions fail (floating, sunk into the floor,
      tilted, pushed through a wall, pushed into a neighbour; every object also gets a little registration
      noise), seeded per scene.
  registration: the real pipeline on captures of ``--preset`` (``all``: standard and cluttered; a preset
      of ``EXTRA_PRESETS`` such as egocentric is run only when named, and then from gt-perturbed poses too;
      ``write_synth``, then ``rescene run``; completed captures and run directories under WORK/captures
      and WORK/runs are reused): the registered poses of the run's generated assets, attached again here
      stage by stage. Errors are bounding-box centres of the placed generated meshes against the
      ground-truth object each instance belongs to.
Graphs: gt-perturbed uses the ground-truth relations over object ids (wall ids removed, so the solver
resolves the wall root itself); the registration start is measured twice, with the run's fused graph and
with the ground-truth relations over instance ids (wall ids removed), and for each graph twice more with
the ground-truth meshes registered to the same instance points by the same registration (exact shapes).
Stages: none, relations (relational layer only), repair (+ room/wall repair), full (+ depenetration).
Per stage: oob_rate, collision_pairs, collision_rate, floor/wall/support contact pass rates,
pose_err_median (m, bounding-box centre vs ground truth), rot_err_median (deg), seconds (attach only).
Seed sets: the development seeds (``--seeds``, 0-4 by default: development decisions are made on them) and
the held-out seeds (``--held-out``, e.g. 100-119: reported as they come) run alike; the summary has one block
per set, each with its seeds and the same figures, never pooled into one mean.
Scaling: the full solver on grids of 20 and 80 perturbed boxes.
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np

from rescene_core.assembly import AssemblyObject, attach
from rescene_core.assembly.objects import footprint
from rescene_core.assembly.scenes import grid_scene
from rescene_core.assembly.transforms import rigid_change, rotation_about, translation
from rescene_core.bench import format_seeds, seed_sets
from rescene_core.config import AttachmentConfig
from rescene_core.evaluation.structural import structural_metrics
from rescene_core.records import Edge, InstanceId, RoomShell, Root, SceneGraph

STAGES: tuple[Literal["none", "relations", "repair", "full"], ...] = ("none", "relations", "repair", "full")
PRESETS = ("standard", "cluttered")
"""What ``--preset all`` measures, and the gt-perturbed start of every run."""
EXTRA_PRESETS = ("egocentric",)
"""Presets measured only when named (``--preset egocentric``): both starts, besides the gt-perturbed ones above."""
METRICS = (
    "oob_rate",
    "collision_pairs",
    "collision_rate",
    "floor_contact_pass",
    "wall_contact_pass",
    "support_contact_pass",
    "pose_err_median",
    "rot_err_median",
    "seconds",
)
FAILURE_MODES = ("none", "floating", "sunk", "tilted", "through_wall", "interpenetrating")
FAILURE_PROBS = (0.25, 0.2, 0.15, 0.15, 0.1, 0.15)
"""How often each failure is drawn per object."""
NOISE_XY = 0.01
"""Registration noise on every object: xy standard deviation (m)."""
NOISE_YAW_DEG = 1.0
"""Registration noise on every object: yaw standard deviation (deg)."""


def ground_truth_layout(preset: str, seed: int):
    """(objects, relations graph, shell, source) of a synthetic scene, without rendering its frames.

    Uses the generator's own room and furnishing steps with the seeds make_scene draws, so the layout is
    the one make_scene(preset, seed) writes as ground truth; falls back to make_scene when those steps
    are not available.
    """
    try:
        from rescene_core.capture.synth.layout import furnish, random_room
        from rescene_core.capture.synth.presets import get_preset

        cfg = get_preset(preset)
        root_rng = np.random.default_rng(seed)
        seed_seq = root_rng.bit_generator.seed_seq
        assert isinstance(seed_seq, np.random.SeedSequence)  # default_rng(int) seeds with a SeedSequence
        rng_layout = np.random.default_rng(seed_seq.spawn(6)[0])
        room = random_room(rng_layout, cfg)
        lay = furnish(room, cfg, rng_layout)
        items = [
            (o.object_id, o.label, *o.model.union_mesh(), o.world_from_object, o.relation, o.parent, o.wall_id)
            for o in lay.objects
        ]
        shell, source = room.shell(), "synth layout (make_scene's seeds, frames not rendered)"
    except (ImportError, AttributeError):
        from rescene_core.capture.synth import make_scene

        gt = make_scene(preset, seed).gt
        rel = {r.child: r for r in gt.relations}
        items = [
            (
                o.object_id,
                o.label,
                o.vertices,
                o.faces,
                o.world_from_object,
                rel[o.object_id].relation,
                rel[o.object_id].parent,
                rel[o.object_id].wall_id,
            )
            for o in gt.objects
        ]
        shell, source = gt.shell, "make_scene ground truth"
    objects = {
        InstanceId(oid): AssemblyObject(
            InstanceId(oid),
            label,
            np.asarray(v, np.float64),
            np.asarray(f, np.int64),
            np.asarray(pose, np.float64),
            exact_shape=True,
        )
        for oid, label, v, f, pose, *_ in items
    }
    edges = tuple(
        Edge(InstanceId(oid), relation, parent if isinstance(parent, Root) else InstanceId(int(parent)), 1.0)
        for oid, _, _, _, _, relation, parent, _ in items
    )
    return objects, SceneGraph(edges), shell, source


def box_centre(vertices: np.ndarray) -> np.ndarray:
    """Centre [3] (m) of the axis-aligned bounding box of ``vertices`` [n, 3]: where the pose errors of this
    suite are measured."""
    return 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))


def _nearest_wall(shell: RoomShell, point: np.ndarray):
    best = None
    for w in shell.walls:
        n = np.asarray(w.plane.normal)
        d = float(point @ n + w.plane.offset)
        if best is None or d < best[0]:
            best = (d, n)
    return best


def perturb(objects: dict, graph: SceneGraph, shell: RoomShell, seed: int) -> tuple[dict, dict[int, str]]:
    """Perturbed copies of ``objects`` (see module docstring) and the failure drawn for each."""
    from dataclasses import replace

    rng = np.random.default_rng(10_000 + seed)
    parent = {e.child: e.parent for e in graph.edges}
    out, modes = {}, {}
    centres = {i: o.world_vertices().mean(axis=0) for i, o in objects.items()}
    for i, obj in objects.items():
        v = obj.world_vertices()
        centre = box_centre(v)
        mode = FAILURE_MODES[rng.choice(len(FAILURE_MODES), p=FAILURE_PROBS)]
        on_wall = parent.get(i) is Root.WALL
        if mode == "interpenetrating" and on_wall:
            mode = "floating"
        noise = translation([*rng.normal(0, NOISE_XY, 2), 0.0]) @ rotation_about(
            [0, 0, np.radians(rng.normal(0, NOISE_YAW_DEG))], centre
        )
        if mode == "floating":
            err = translation([0, 0, rng.uniform(0.03, 0.25)])
        elif mode == "sunk":
            err = translation([0, 0, -rng.uniform(0.02, 0.10)])
        elif mode == "tilted":
            axis = rng.normal(size=2)
            axis = np.array([*axis / np.linalg.norm(axis), 0.0])
            err = rotation_about(axis * np.radians(rng.uniform(3.0, 10.0)), centre)
        elif mode == "through_wall":
            gap, n = _nearest_wall(shell, v[np.argmin(v @ _nearest_wall(shell, centre)[1])])
            err = translation(-n * (max(gap, 0.0) + rng.uniform(0.03, 0.15)))
        elif mode == "interpenetrating":
            others = [
                j
                for j in objects
                if j != i and parent.get(j) is not Root.WALL and parent.get(j) != i and parent.get(i) != j
            ]
            if others:
                j = min(others, key=lambda j: np.linalg.norm(centres[j][:2] - centre[:2]))
                d = centres[j][:2] - centre[:2]
                d = d / max(np.linalg.norm(d), 1e-9)
                gap = footprint(v).distance(footprint(objects[j].world_vertices()))
                err = translation([*(d * (gap + rng.uniform(0.03, 0.12))), 0.0])
            else:
                err = np.eye(4)
        else:
            err = np.eye(4)
        modes[int(i)] = mode
        out[i] = replace(obj, world_from_asset=err @ noise @ obj.world_from_asset)
    return out, modes


def metric_objects(objects: dict, layout) -> dict:
    """``objects`` as the exported scene has them: each mesh with the completions the solver added from its
    observed points (``Layout.completions``: a shelf board or a base the generated mesh lacks, which the
    exporter adds as colliders) appended in its asset frame."""
    from dataclasses import replace

    from rescene_core.geometry.completion import completed_mesh

    out = dict(objects)
    for i, completions in layout.completions().items():
        obj = objects[InstanceId(int(i))]
        vertices, faces = completed_mesh(obj.vertices, obj.faces, completions)
        out[InstanceId(int(i))] = replace(obj, vertices=vertices, faces=faces)
    return out


def visual_objects(objects: dict, layout) -> dict:
    """``objects`` with the meshes the exported scene shows: cut at the layout's cut planes (a completion
    through a wall or the floor, ``assembly/trim.py``), nothing added."""
    from dataclasses import replace

    from rescene_core.geometry.completion import cut_mesh
    from rescene_core.records import CompletionKind

    out = dict(objects)
    for i, completions in layout.completions().items():
        cuts = [c for c in completions if c.kind is CompletionKind.CUT]
        if cuts:
            obj = objects[InstanceId(int(i))]
            vertices, faces = cut_mesh(obj.vertices, obj.faces, cuts)
            out[InstanceId(int(i))] = replace(obj, vertices=vertices, faces=faces)
    return out


def pose_errors(gt: dict, objects: dict, poses: dict) -> tuple[float, float]:
    """Median bounding-box-centre error (m) and median rotation error (deg) against ground truth."""
    t_err, r_err = [], []
    for i, g in gt.items():
        gv = g.world_vertices()
        pv = objects[i].world_vertices(poses[i])
        t_err.append(np.linalg.norm(box_centre(gv) - box_centre(pv)))
        r_err.append(rigid_change(g.world_from_asset, poses[i])[1])
    return float(np.median(t_err)), float(np.median(r_err))


def run_stages(
    gt: dict, objects: dict, graph: SceneGraph, shell: RoomShell, poses_out: dict | None = None
) -> dict[str, dict[str, Any]]:
    """Metrics of every stage from ``objects``' poses against ``gt``; ``poses_out`` receives each stage's poses."""
    out: dict[str, dict[str, Any]] = {}
    for stage in STAGES:
        if stage == "none":
            poses, seconds, layout = {i: o.world_from_asset for i, o in objects.items()}, 0.0, None
        else:
            start = time.perf_counter()
            layout = attach(objects, graph, shell, AttachmentConfig(stop_after=stage))
            seconds = time.perf_counter() - start
            poses = layout.world_from_asset
        if poses_out is not None:
            poses_out[stage] = poses
        m = structural_metrics(objects, poses, graph, shell)
        t_err, r_err = pose_errors(gt, objects, poses)
        out[stage] = {
            **{k: m[k] for k in METRICS if k in m},
            "pose_err_median": t_err,
            "rot_err_median": r_err,
            "seconds": seconds,
            "operations": 0 if layout is None else len(layout.operations),
            "oob_objects": m["oob_objects"],
            "colliding": m["colliding"],
            "contact_failures": m["contact_failures"],
        }
    return out


def scaling(repeats: int = 3) -> dict[str, Any]:
    """Seconds of the full solver on grids of 20 and 80 perturbed boxes (best of ``repeats``)."""
    out = {}
    for n in (20, 80):
        objs, graph, shell = grid_scene(n, seed=n)
        best = np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            attach(objs, graph, shell, AttachmentConfig())
            best = min(best, time.perf_counter() - start)
        out[str(n)] = best
    out["ratio_80_over_20"] = out["80"] / out["20"]
    return out


def draw_plan(path: Path, shell: RoomShell, objects: dict, panels: dict[str, dict]) -> None:
    """Top-down plans, one panel per named pose set: footprints, colliding (red) and out-of-room (orange)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from shapely.geometry import MultiPoint

    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 5))
    for ax, (title, info) in zip(np.atleast_1d(axes), panels.items()):
        poly = np.asarray(shell.floor_polygon + (shell.floor_polygon[0],))
        ax.plot(poly[:, 0], poly[:, 1], "k-", lw=2)
        bad = {i for pair in info["colliding"] for i in pair}
        for i, obj in objects.items():
            hull = MultiPoint(obj.world_vertices(info["poses"][i])[:, :2]).convex_hull
            if hull.geom_type != "Polygon":
                continue
            x, y = hull.exterior.xy
            color = "tab:red" if int(i) in bad else "tab:orange" if int(i) in info["oob"] else "tab:blue"
            ax.fill(x, y, alpha=0.35, color=color)
            ax.plot(x, y, color=color, lw=0.8)
            c = hull.centroid
            ax.text(c.x, c.y, f"{int(i)}", fontsize=6, ha="center", va="center")
        ax.set_title(title, fontsize=9)
        ax.set_aspect("equal")
    fig.suptitle(
        "footprints: blue placed, red colliding, orange out of the room; labels are object or instance ids", fontsize=8
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def perturbed_scene(preset: str, seed: int, work_dir: Path, plan: bool = False) -> dict[str, Any]:
    """The gt-perturbed start of one scene, stage by stage; with ``plan`` its before/after plan is drawn
    to ``work_dir/plans/<preset>_<seed>.png``."""
    gt_objects, graph, shell, source = ground_truth_layout(preset, seed)
    # the solver resolves the wall root itself: the graph names no concrete wall
    graph = SceneGraph(tuple(Edge(e.child, e.relation, e.parent, e.confidence) for e in graph.edges))
    start_objects, modes = perturb(gt_objects, graph, shell, seed)
    gt_metrics = structural_metrics(gt_objects, None, graph, shell)
    stage_poses: dict[str, dict] = {}
    stages = run_stages(gt_objects, start_objects, graph, shell, stage_poses)
    if plan:
        panels = {
            "ground truth": _panel({i: o.world_from_asset for i, o in gt_objects.items()}, gt_metrics),
            "perturbed (before)": _panel(stage_poses["none"], stages["none"]),
            "full attachment (after)": _panel(stage_poses["full"], stages["full"]),
        }
        draw_plan(work_dir / "plans" / f"{preset}_{seed}.png", shell, start_objects, panels)
    return {
        "preset": preset,
        "seed": seed,
        "source": source,
        "objects": len(gt_objects),
        "start": "gt-perturbed",
        "graph": "gt",
        "failures": {m: sum(1 for v in modes.values() if v == m) for m in FAILURE_MODES},
        "ground_truth": {
            k: gt_metrics[k]
            for k in ("oob_rate", "collision_pairs", "floor_contact_pass", "wall_contact_pass", "support_contact_pass")
        },
        "stages": stages,
    }


def summarise(
    scenes: list[dict[str, Any]],
    registration: list[dict[str, Any]],
    gt_presets: tuple[str, ...],
    registration_presets: tuple[str, ...],
) -> dict[str, Any]:
    """Means over the scenes of one seed set: per gt-perturbed preset, and per registration start
    (``registration_key``: preset, graph, shapes) with the physics line under the fused graph's."""
    summary: dict[str, Any] = {}
    for name in gt_presets:
        rows = [s for s in scenes if s["preset"] == name]
        if not rows:
            continue
        summary[name] = {stage: {k: _mean([r["stages"][stage][k] for r in rows]) for k in METRICS} for stage in STAGES}
        summary[name]["full"]["seconds_max"] = max(r["stages"]["full"]["seconds"] for r in rows)
    for name in registration_presets:
        rows = [r for r in registration if r["preset"] == name]
        if not rows:
            continue
        for shapes, field in zip(REGISTRATION_SHAPES, ("graphs", "exact_shapes"), strict=True):
            for graph_name in REGISTRATION_GRAPHS:
                summary[registration_key(name, graph_name, shapes)] = {
                    stage: {
                        k: _mean([r[field][graph_name][stage][k] for r in rows]) for k in (*METRICS, "pose_err_mean")
                    }
                    for stage in STAGES
                }
        summary[registration_key(name, "fused")]["physics"] = physics_summary(rows)
    return summary


def run(seeds: list[int], preset: str, work_dir: Path, held_out: list[int] | None = None) -> dict[str, Any]:
    """Run the suite on both presets from gt-perturbed poses; from registration poses on ``preset`` (``all``:
    both presets; the registration start runs the whole pipeline on each capture once, cached in ``work_dir``).
    A preset of ``EXTRA_PRESETS`` is measured from both starts as well.

    Seed sets (``seed_sets``): the development ``seeds`` and the ``held_out`` seeds are run alike and
    summarised apart, one summary block each with its seeds; every scene names its ``seed_set``."""
    work_dir = Path(work_dir)
    selectable = PRESETS + EXTRA_PRESETS
    registration_presets = PRESETS if preset == "all" else (preset if preset in selectable else "standard",)
    gt_presets = PRESETS + ((preset,) if preset in EXTRA_PRESETS else ())
    have_registration = all(importlib.util.find_spec(m) for m in ("rescene_core.registration", "rescene_core.assets"))
    not_run: dict[str, str] = {}
    if not have_registration:
        not_run["registration_start"] = "rescene_core.registration / rescene_core.assets not importable"
    scenes: list[dict[str, Any]] = []
    registration: list[dict[str, Any]] = []
    summary: dict[str, dict[str, Any]] = {}
    for seed_set, set_seeds in seed_sets(seeds, held_out).items():
        set_scenes = [
            {"seed_set": seed_set, **perturbed_scene(name, seed, work_dir, plan=seed == set_seeds[0])}
            for name in gt_presets
            for seed in set_seeds
        ]
        set_registration = []
        for name in registration_presets if have_registration else ():
            for seed in set_seeds:
                try:
                    set_registration.append({"seed_set": seed_set, **registration_scene(seed, work_dir, name)})
                except Exception as exc:  # a pipeline failure is reported, not hidden
                    not_run[f"registration_{name}_seed{seed}"] = f"{type(exc).__name__}: {exc}"
        summary[seed_set] = {
            "seeds": set_seeds,
            **summarise(set_scenes, set_registration, gt_presets, registration_presets),
        }
        scenes += set_scenes
        registration += set_registration
    return {
        "summary": summary,
        "registration_scenes": registration,
        "scenes": scenes,
        "scaling": scaling(),
        "plans": sorted(str(p) for p in (work_dir / "plans").glob("*.png")),
        "not_run": not_run,
    }


REGISTRATION_GRAPHS = ("fused", "gt")
"""Graphs of the registration start: the run's fused graph, and the ground-truth relations over instance ids
(wall ids removed: they name ground-truth walls, not the run's estimated ones), which separates the solver's
losses from the graph's."""


REGISTRATION_SHAPES = ("generated", "exact")
"""Meshes of the registration start: the run's generated assets at their registered poses, and the
ground-truth meshes registered by the same registration to the same instance points (``exact``), which
separates what the solver does to good shapes from what generated shapes' errors cost."""


def registration_key(preset: str, graph: str, shapes: str = "generated") -> str:
    """Summary key of the registration start (``registration`` alone: standard preset, fused graph, the
    run's generated assets)."""
    return (
        "registration"
        + ("" if preset == "standard" else f"_{preset}")
        + ("" if shapes == "generated" else f"_{shapes}_shapes")
        + ("" if graph == "fused" else f"_{graph}_graph")
    )


def exact_shape_objects(capture, gt, instances, cache: Path) -> dict[InstanceId, AssemblyObject]:
    """Ground-truth meshes registered to each instance's points, as exact shapes (asset frame = the object's
    own axes, unit-box scaled); poses cached in ``cache`` (JSON). Instances registration misses are left out."""
    import json

    from rescene_core.assets import unit_box_normalisation
    from rescene_core.config import RegistrationConfig
    from rescene_core.geometry import sim3
    from rescene_core.io import write_json_atomic
    from rescene_core.records import Asset, Missing
    from rescene_core.registration import register

    obj_of = gt.object_of_instance()
    by_id = {o.object_id: o for o in gt.objects}
    poses = json.loads(cache.read_text()) if cache.exists() else {}
    out = {}
    for i in sorted(instances):
        if int(i) not in obj_of:
            continue
        obj = by_id[obj_of[int(i)]]
        verts = sim3.apply(unit_box_normalisation(obj.vertices), obj.vertices)
        if str(int(i)) not in poses:
            asset = Asset(i, verts, np.asarray(obj.faces, np.int64), "gt", {"label": obj.label})
            pose = register(asset, capture.point_cloud(int(i)), RegistrationConfig())
            poses[str(int(i))] = None if isinstance(pose, Missing) else np.asarray(pose.world_from_asset).tolist()
        if poses[str(int(i))] is not None:
            out[i] = AssemblyObject(
                i, obj.label, verts, np.asarray(obj.faces, np.int64), np.asarray(poses[str(int(i))]), exact_shape=True
            )
    write_json_atomic(cache, poses)
    return out


def registration_scene(seed: int, work_dir: Path, preset: str = "standard") -> dict[str, Any]:
    """Stages of attachment from the real pipeline's registered poses, with the run's fused graph and with the
    ground-truth graph (see module doc and ``REGISTRATION_GRAPHS``)."""
    from rescene_core.bench.runs import pipeline_run, synth_capture
    from rescene_core.capture import open_capture
    from rescene_core.capture.ground_truth import read_ground_truth
    from rescene_core.evaluation.scene import load_scene

    capture = synth_capture(work_dir, preset, seed)
    run_dir = pipeline_run(capture, work_dir / "runs" / f"{preset}_seed{seed}")
    doc = load_scene(run_dir)
    cap = open_capture(capture, validate=False)
    gt = read_ground_truth(cap)
    assert gt is not None, f"{capture} is a synthetic capture with ground truth"
    shell = doc.scene.shell
    assert shell is not None, "the pipeline's export always records the room shell"
    obj_of = gt.object_of_instance()
    objects = {
        o.instance: AssemblyObject(
            o.instance,
            o.label,
            *doc.meshes[o.instance],
            o.registered_world_from_asset,
            points=np.asarray(cap.point_cloud(int(o.instance)).points, np.float64),
        )
        for o in doc.scene.objects
        if o.registered_world_from_asset is not None
    }
    gt_centre = {}
    for i in objects:
        if int(i) in obj_of:
            gv = np.asarray(gt.world_mesh(obj_of[int(i)]).vertices)
            gt_centre[i] = box_centre(gv)
    fused_graph = doc.scene.graph
    gt_graph = gt.graph_by_instance()
    graphs = {
        "fused": fused_graph,
        "gt": SceneGraph(tuple(Edge(e.child, e.relation, e.parent, e.confidence) for e in gt_graph.edges)),
    }
    exact = exact_shape_objects(cap, gt, set(objects), run_dir / "exact_shape_poses.json")
    fused_poses: dict[str, dict] = {}
    stages = {
        name: _registration_stages(objects, g, shell, gt_centre, fused_poses if name == "fused" else None)
        for name, g in graphs.items()
    }
    draw_plan(
        work_dir / "plans" / f"registration_{preset}_{seed}.png",
        shell,
        objects,
        {
            "registered (before)": _panel(fused_poses["none"], stages["fused"]["none"]),
            "full attachment (after)": _panel(fused_poses["full"], stages["fused"]["full"]),
        },
    )
    return {
        "preset": preset,
        "seed": seed,
        "start": "registration",
        "run_dir": str(run_dir),
        "objects": len(objects),
        "matched_to_gt": len(gt_centre),
        "exact_shapes_registered": len(exact),
        "graphs": stages,
        "exact_shapes": {
            name: _registration_stages(exact, g, shell, {i: gt_centre[i] for i in exact}) for name, g in graphs.items()
        },
        "physics": registration_physics(
            objects, fused_graph, shell, work_dir / "sim" / f"{preset}_seed{seed}", work_dir
        ),
    }


def registration_physics(
    objects: dict, graph: SceneGraph, shell: RoomShell, run_dir: Path, work_dir: Path
) -> dict[str, Any]:
    """The physics check on the full-stage layout (the generated assets, ``graph``): the layout with its
    completions exported as a scene under ``run_dir`` (MJCF, USD; CoACD results cached on the mesh hash
    under WORK/convex_cache) and ``rescene_core.sim.simcheck_run`` on it (2 s under gravity)."""
    import shutil

    from rescene_core.export import ExportConfig, export_scene, placed_objects
    from rescene_core.paths import RunPaths
    from rescene_core.sim import SimcheckConfig, simcheck_run

    started = time.perf_counter()
    layout = attach(objects, graph, shell, AttachmentConfig())
    attached = time.perf_counter()
    completions = layout.completions()
    placed = [o for i, o in sorted(objects.items()) if i in layout.world_from_asset]
    export_objects = placed_objects(placed, layout)
    shutil.rmtree(run_dir, ignore_errors=True)
    config = ExportConfig(decomposition_cache=str(work_dir / "convex_cache"))
    export_scene(RunPaths(run_dir).scene, export_objects, shell, graph, layout.missing, config)
    exported = time.perf_counter()
    check = simcheck_run(run_dir, SimcheckConfig())
    s = check.summary
    return {
        "run_dir": str(run_dir),
        "free": s.free,
        "stable": s.stable,
        "stable_fraction": s.stable_fraction,
        "penetration_t0_max": s.penetration_t0_max,
        "fell_through": s.fell_through,
        "escaped": s.escaped,
        "unstable": [o.node for o in check.objects if o.kind == "free" and not o.stable],
        "completions": sum(len(c) for c in completions.values()),
        "seconds": {
            "attach": round(attached - started, 2),
            "export": round(exported - attached, 2),
            "simcheck": round(time.perf_counter() - exported, 2),
        },
    }


def physics_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The physics check over scenes (``registration_physics`` of each): stable fraction over all free
    objects, the deepest t=0 penetration, fallen and escaped objects, seconds added per scene."""
    done = [r["physics"] for r in rows if "physics" in r]
    free = sum(p["free"] for p in done)
    return {
        "scenes": len(done),
        "free": free,
        "stable_fraction": round(sum(p["stable"] for p in done) / free, 4) if free else None,
        "per_scene": [p["stable_fraction"] for p in done],
        "penetration_t0_max": max((p["penetration_t0_max"] for p in done), default=None),
        "fell_through": sum(p["fell_through"] for p in done),
        "escaped": sum(p["escaped"] for p in done),
        "seconds_per_scene": round(float(np.mean([sum(p["seconds"].values()) for p in done])), 1) if done else None,
    }


def _panel(poses: dict, metrics: dict) -> dict[str, Any]:
    """One ``draw_plan`` panel: poses, and the colliding pairs and out-of-room objects measured on them."""
    return {"poses": poses, "colliding": metrics["colliding"], "oob": set(metrics["oob_objects"])}


def moved_by_attachment(objects: dict, poses: dict) -> list[float]:
    """How far (m) attachment moved each object's bounding-box centre (its full mesh, as registered) from
    its registered pose to ``poses`` [4, 4] each (issue 27: no object moved more than the correction bound)."""
    return [
        float(np.linalg.norm(box_centre(obj.world_vertices(poses[i])) - box_centre(obj.world_vertices())))
        for i, obj in objects.items()
        if i in poses
    ]


def _registration_stages(
    objects: dict, graph: SceneGraph, shell: RoomShell, gt_centre: dict, poses_out: dict | None = None
) -> dict[str, Any]:
    """Metrics of every stage from the registered poses; ``poses_out`` receives each stage's poses. Besides
    the structural metrics and the pose error: ``moved_max_m``, the largest move of an object's centre by
    attachment (m), and ``moved_over_bound``, how many objects moved more than ``max_correction_m``."""
    bound = AttachmentConfig().max_correction_m
    stages: dict[str, Any] = {}
    for stage in STAGES:
        if stage == "none":
            poses, seconds, scene_objects = {i: o.world_from_asset for i, o in objects.items()}, 0.0, objects
            visual = objects
        else:
            start = time.perf_counter()
            layout = attach(objects, graph, shell, AttachmentConfig(stop_after=stage))
            seconds = time.perf_counter() - start
            poses, scene_objects = layout.world_from_asset, metric_objects(objects, layout)
            visual = visual_objects(objects, layout)
        if poses_out is not None:
            poses_out[stage] = poses
        # contacts as the exported scene has them: with the support planes found in the parents' points
        m = structural_metrics(scene_objects, poses, graph, shell)
        err = []
        for i, c in gt_centre.items():
            pv = visual[i].world_vertices(poses[i])  # the exported mesh: cut, without colliders added
            err.append(float(np.linalg.norm(box_centre(pv) - c)))
        moved = moved_by_attachment(objects, poses)
        stages[stage] = {
            **{k: m[k] for k in METRICS if k in m},
            "pose_err_median": float(np.median(err)) if err else None,
            "pose_err_mean": float(np.mean(err)) if err else None,
            "rot_err_median": None,
            "moved_max_m": max(moved, default=0.0),
            "moved_over_bound": None if bound is None else sum(m > bound for m in moved),
            "seconds": seconds,
            "oob_objects": m["oob_objects"],
            "colliding": m["colliding"],
            "contact_failures": m["contact_failures"],
        }
    return stages


def _mean(values):
    vals = [v for v in values if v is not None]
    return float(np.mean(vals)) if vals else None


SET_NOTES = {"development": "development decisions are made on these", "held_out": "reported as they come"}


def table(result: dict[str, Any]) -> str:
    """One block per seed set (development, then held out: never pooled), each with its seeds in the
    heading; in a block one table of stages per start, and the physics line under the registration start's."""
    lines = []
    if "held_out" not in result["summary"]:
        lines.append("no held-out seeds (--held-out)")
    for seed_set, block in result["summary"].items():
        seeds = format_seeds(block["seeds"])
        lines.append(f"== {seed_set} seeds {seeds} ({SET_NOTES[seed_set]})")
        for name, stages in block.items():
            if name == "seeds":
                continue
            lines += _stage_table(name, stages, seed_set, seeds)
    lines += _full_stage_by_seed_set(result["summary"])
    s = result["scaling"]
    lines.append(f"scaling: 20 objects {s['20']:.3f} s, 80 objects {s['80']:.3f} s, ratio {s['ratio_80_over_20']:.2f}")
    for key, why in result["not_run"].items():
        lines.append(f"{key}: {why}")
    return "\n".join(lines)


OVERVIEW = (
    "oob_rate",
    "collision_rate",
    "floor_contact_pass",
    "wall_contact_pass",
    "support_contact_pass",
    "pose_err_median",
)
"""The full stage's figures the seed sets are set side by side on, with the physics check's stable fraction."""


def _full_stage_by_seed_set(summary: dict[str, Any]) -> list[str]:
    """The full stage of every start, one row per seed set under each other (rows, never a pooled mean)."""
    names = [n for block in summary.values() for n in block if n != "seeds"]
    lines = [
        "full stage by seed set",
        f"{'start':<36} {'seeds':<11} " + " ".join(f"{k[:13]:>13}" for k in OVERVIEW) + f" {'stable 2 s':>10}",
    ]
    for name in dict.fromkeys(names):
        for seed_set, block in summary.items():
            if name not in block:
                continue
            row = block[name]["full"]
            cells = " ".join(f"{'-' if row.get(k) is None else format(row[k], '.4f'):>13}" for k in OVERVIEW)
            stable = (block[name].get("physics") or {}).get("stable_fraction")
            lines.append(f"{name:<36} {seed_set:<11} {cells} {'-' if stable is None else format(stable, '.3f'):>10}")
    return lines


def _stage_table(name: str, stages: dict[str, Any], seed_set: str, seeds: str) -> list[str]:
    if name.startswith("registration"):
        shapes = "ground-truth meshes registered" if "_exact_shapes" in name else "generated assets"
        what = f"registration start, {shapes}, {'ground-truth' if name.endswith('_gt_graph') else 'fused'} graph"
    else:
        what = "gt-perturbed start, gt graph"
    lines = [
        f"{name} ({what}, mean over {seed_set} seeds {seeds})",
        "stage      " + " ".join(f"{k[:13]:>13}" for k in METRICS),
    ]
    for stage in STAGES:
        row = stages[stage]
        cells = " ".join(f"{'-' if row[k] is None else format(row[k], '.4f'):>13}" for k in METRICS)
        lines.append(f"{stage:<10} {cells}")
    if (p := stages.get("physics")) and p["stable_fraction"] is not None:
        pen = "-" if p["penetration_t0_max"] is None else f"{p['penetration_t0_max'] * 1000:.1f} mm"
        lines.append(
            f"physics (full stage, 2 s): stable {p['stable_fraction']:.3f} of {p['free']} free objects "
            f"(per scene {p['per_scene']}), t=0 penetration max {pen}, fell {p['fell_through']}, "
            f"escaped {p['escaped']}, {p['seconds_per_scene']} s per scene"
        )
    return lines
