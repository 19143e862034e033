"""``make_scene``: a furnished room, its camera walk, rendered frames with panoptic errors, fused instance
point clouds, and the ground truth. ``write_synth`` writes it as a capture with a ``gt/`` group."""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import box as shapely_box

from rescene_core.capture.format import CaptureArrays, points_to_csr, write_capture
from rescene_core.capture.ground_truth import GroundTruth, GtObject, GtRelation, GtStructure, write_ground_truth
from rescene_core.capture.synth.cameras import CameraPlan, plan_cameras
from rescene_core.capture.synth.layout import Layout, Room, furnish, random_room
from rescene_core.capture.synth.objects import CONFUSABLE, WOODS
from rescene_core.capture.synth.panoptic import Accumulator, boundary_noise, depth_with_noise, drift
from rescene_core.capture.synth.presets import SynthPreset, get_preset
from rescene_core.records import Camera, Instance, InstanceId
from rescene_core.render import Light, Renderer, RenderMesh, Shading, Texture

OBJECT_RENDER_BASE = 1 << 14
"""Render ids of objects are OBJECT_RENDER_BASE + object id; structure renders with its instance id."""


@dataclass
class SynthScene:
    """A generated capture in memory.

    arrays: the capture. gt: its ground truth. object_id_frames: int32 [T, H, W] error-free object id per
    pixel (0 = structure or nothing). plan: the cameras and why each was taken. events: the panoptic errors
    that were applied ({"kind": "drift" | "split" | "missed" | "wrong_label", ...}). timings: seconds per step.
    """

    preset: SynthPreset
    seed: int
    arrays: CaptureArrays
    gt: GroundTruth
    object_id_frames: NDArray[np.int32]
    plan: CameraPlan
    layout: Layout
    events: list[dict[str, Any]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)


def _triangulate(poly) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices [v, 2] and faces [f, 3] (counter-clockwise) of a constrained triangulation of a polygon."""
    tris = shapely.constrained_delaunay_triangles(poly)
    coords = np.array([np.asarray(t.exterior.coords)[:3] for t in tris.geoms])
    verts, inv = np.unique(coords.reshape(-1, 2), axis=0, return_inverse=True)
    faces = inv.reshape(-1, 3).astype(np.int64)
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    cw = ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]) < 0
    faces[cw] = faces[cw][:, ::-1]
    return verts, faces


def _structure_meshes(
    room: Room, lay: Layout, rng: np.random.Generator
) -> tuple[list[RenderMesh], list[GtStructure], list[Instance]]:
    """Floor, one mesh per wall plane, ceiling: render meshes, structure records, instance records."""
    meshes, structure, instances = [], [], []
    poly = room.polygon
    v2, f = _triangulate(poly)
    floor_v = np.column_stack([v2, np.zeros(len(v2))])
    floor_col = np.asarray(WOODS[int(rng.integers(len(WOODS)))]) * rng.uniform(0.95, 1.15)
    iid = 1
    meshes.append(
        RenderMesh.uniform(iid, floor_v, f, np.clip(floor_col, 0, 1), Texture.PLANKS, texture_seed=rng.uniform())
    )
    structure.append(GtStructure(iid, "floor"))
    instances.append(Instance(InstanceId(iid), "floor", True))
    paints = ((0.9, 0.88, 0.83), (0.86, 0.88, 0.9), (0.88, 0.85, 0.78), (0.8, 0.85, 0.8), (0.92, 0.9, 0.9))
    paint = np.asarray(paints[int(rng.integers(len(paints)))])
    accent = int(rng.integers(len(room.walls)))
    door = getattr(lay, "door", None)
    h = room.height
    for wall in room.walls:
        iid += 1
        p0, p1 = np.array(wall.segment[0]), np.array(wall.segment[1])
        verts = [[*p0, 0.0], [*p1, 0.0], [*p1, h], [*p0, h]]
        faces = [[0, 1, 2], [0, 2, 3]]
        col = paint * (0.85 if wall.id == accent else 1.0) * np.array([1.0, 0.98, 0.97] if wall.id == accent else 1.0)
        cols = [col, col]
        tex = [Texture.PAINT, Texture.PAINT]
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        n = np.array(wall.plane.normal[:2])
        if door is not None and door[0] == wall.id:
            s = door[1]
            a, b = p0 + u * (s - 0.45) + n * 0.01, p0 + u * (s + 0.45) + n * 0.01
            k = len(verts)
            verts += [[*a, 0.0], [*b, 0.0], [*b, 2.05], [*a, 2.05]]
            faces += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
            dcol = np.asarray(WOODS[int(rng.integers(len(WOODS)))])
            cols += [dcol, dcol]
            tex += [Texture.WOOD, Texture.WOOD]
        frame = np.eye(4)  # wall paint is isotropic: evaluate it in world coordinates (cheaper)
        meshes.append(
            RenderMesh(
                iid,
                np.asarray(verts, np.float64),
                np.asarray(faces, np.int64),
                np.asarray(cols, np.float32),
                np.asarray(tex, np.uint8),
                frame,
                float(rng.uniform()),
            )
        )
        structure.append(GtStructure(iid, "wall", wall.id))
        instances.append(Instance(InstanceId(iid), "wall", True))
    iid += 1
    meshes.append(RenderMesh.uniform(iid, floor_v + [0, 0, h], f, (0.95, 0.95, 0.94), Texture.PLAIN))
    structure.append(GtStructure(iid, "ceiling"))
    instances.append(Instance(InstanceId(iid), "ceiling", True))
    return meshes, structure, instances


def _object_mesh(obj, rng: np.random.Generator) -> RenderMesh:
    pose = obj.world_from_object
    verts, faces, cols, tex, off = [], [], [], [], 0
    for part in obj.model.parts:
        verts.append(part.vertices @ pose[:3, :3].T + pose[:3, 3])
        faces.append(part.faces + off)
        cols.append(np.tile(np.asarray(part.color, np.float32), (len(part.faces), 1)))
        tex.append(np.full(len(part.faces), part.texture, np.uint8))
        off += len(part.vertices)
    return RenderMesh(
        OBJECT_RENDER_BASE + obj.object_id,
        np.concatenate(verts),
        np.concatenate(faces),
        np.concatenate(cols),
        np.concatenate(tex),
        pose,
        float(rng.uniform()),
    )


def _lights(room: Room) -> tuple[Light, ...]:
    poly = room.polygon
    z = room.height - 0.25
    if abs(poly.area - poly.envelope.area) < 1e-6:
        c = poly.centroid
        return (Light((c.x, c.y, z), 0.75),)
    x0, y0, x1, y1 = poly.bounds
    out = []
    for half in (shapely_box(x0, y0, (x0 + x1) / 2, y1), shapely_box((x0 + x1) / 2, y0, x1, y1)):
        part = poly.intersection(half)
        c = part.representative_point() if not part.centroid.within(poly) else part.centroid
        out.append(Light((c.x, c.y, z), 0.55))
    return tuple(out)


def make_scene(preset: str | SynthPreset = "tiny", seed: int = 0, **overrides) -> SynthScene:
    """Generate a synthetic capture with ground truth. Same preset, overrides and seed -> same arrays.

    overrides: preset fields to replace (e.g. ``split_prob=1.0``; see ``SynthPreset``).
    """
    cfg = get_preset(preset, **overrides)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    root_rng = np.random.default_rng(seed)
    # default_rng(int) holds a SeedSequence; the stubs type it as the ISeedSequence interface, which has no spawn
    rngs = [np.random.default_rng(s) for s in root_rng.bit_generator.seed_seq.spawn(6)]  # type: ignore[attr-defined]
    rng_layout, rng_cam, rng_look, rng_err, rng_frames, rng_ids = rngs
    room = random_room(rng_layout, cfg)
    lay = furnish(room, cfg, rng_layout)
    plan = plan_cameras(lay, cfg, rng_cam)
    timings["layout"] = time.perf_counter() - t0

    t = time.perf_counter()
    struct_meshes, structure, struct_instances = _structure_meshes(room, lay, rng_look)
    obj_meshes = [_object_mesh(o, rng_look) for o in lay.objects]
    renderer = Renderer(
        struct_meshes + obj_meshes,
        Shading(lights=_lights(room), ambient=0.3, shadows=cfg.shadows, shadow_stride=cfg.shadow_stride),
    )
    timings["scene_build"] = time.perf_counter() - t

    # per-object decisions of the panoptic model: ids, splits, misses, wrong labels
    events: list[dict[str, Any]] = []
    n_struct = len(struct_instances)
    n_obj = len(lay.objects)
    perm = rng_ids.permutation(n_obj)
    primary_of = {lay.objects[int(k)].object_id: n_struct + 1 + j for j, k in enumerate(perm)}
    next_id = n_struct + n_obj + 1
    split_of: dict[int, tuple[int, int, float]] = {}  # object id -> (second instance id, axis, threshold)
    missed: set[int] = set()
    labels: dict[int, str] = {}
    for obj in lay.objects:
        size = obj.model.size
        label = obj.label
        if max(size) < cfg.small_size and not any(o.parent == obj.object_id for o in lay.objects):
            if rng_err.random() < cfg.miss_small_prob:
                missed.add(obj.object_id)
                events.append({"kind": "missed", "object": obj.object_id, "label": label})
                continue
        if max(size) >= cfg.split_min_size and rng_err.random() < cfg.split_prob:
            axis = int(np.argmax(size[:2]))
            lo, hi = obj.model.bounds[0][axis], obj.model.bounds[1][axis]
            thr = float(lo + (hi - lo) * rng_err.uniform(0.35, 0.65))
            split_of[obj.object_id] = (next_id, axis, thr)
            events.append({"kind": "split", "object": obj.object_id, "instances": [primary_of[obj.object_id], next_id]})
            next_id += 1
        if rng_err.random() < cfg.wrong_label_prob and label in CONFUSABLE:
            wrong = CONFUSABLE[label][int(rng_err.integers(len(CONFUSABLE[label])))]
            labels[obj.object_id] = wrong
            events.append({"kind": "wrong_label", "object": obj.object_id, "label": label, "given": wrong})
    lut = np.zeros(OBJECT_RENDER_BASE + n_obj + 1, np.int32)
    for s in structure:
        lut[s.instance_id] = s.instance_id
    for obj in lay.objects:
        if obj.object_id not in missed:
            lut[OBJECT_RENDER_BASE + obj.object_id] = primary_of[obj.object_id]
    object_instance_ids = {primary_of[o] for o in primary_of if o not in missed} | {v[0] for v in split_of.values()}
    local_from_world = {oid: np.linalg.inv(lay.objects[oid - 1].world_from_object) for oid in split_of}

    T, H, W = cfg.frames, cfg.height, cfg.width
    rgb = np.zeros((T, H, W, 3), np.uint8)
    masks = np.zeros((T, H, W), np.int32)
    depth = np.zeros((T, H, W), np.float32)
    obj_frames = np.zeros((T, H, W), np.int32)
    max_id = next_id
    voxel_of = np.full(max_id + 1, cfg.structure_voxel)
    for obj in lay.objects:
        vox = float(np.clip(np.linalg.norm(obj.model.size) * cfg.object_voxel_ratio, *cfg.object_voxel_range))
        voxel_of[primary_of[obj.object_id]] = vox
        if obj.object_id in split_of:
            voxel_of[split_of[obj.object_id][0]] = vox
    acc = Accumulator(voxel_of, cfg.fusion_stride)
    pixel_counts = np.zeros(max_id + 1, np.int64)
    min_px = max(20, H * W // 2000)
    noise_bank = None
    if cfg.rgb_noise > 0:
        bank_rng = np.random.default_rng([seed, 1])
        noise_bank = np.round(bank_rng.standard_normal(H * W * 3 + 65536) * cfg.rgb_noise).astype(np.int16)

    def one_frame(k: int) -> dict[str, Any]:
        # each frame has its own random stream, so the result does not depend on thread scheduling
        rng_k = np.random.default_rng([seed, 2, k])
        cam = Camera(plan.K, plan.world_from_cam[k], W, H)
        t = time.perf_counter()
        frame = renderer.render(cam)
        t_render = time.perf_counter() - t
        t = time.perf_counter()
        rid = frame.ids
        ids = lut[rid]
        for oid, (second, axis, thr) in split_of.items():
            sel = rid == OBJECT_RENDER_BASE + oid
            if sel.any():
                p = frame.hits.points[sel].astype(np.float64)
                local = p @ local_from_world[oid][:3, :3].T + local_from_world[oid][:3, 3]
                ids[sel] = np.where(local[:, axis] > thr, second, ids[sel])
        ids, _ = boundary_noise(ids, cfg, rng_k)
        ids, event = drift(ids, object_instance_ids, cfg, rng_k, min_px)
        d = depth_with_noise(frame.depth, cfg, rng_k)
        img = frame.rgb
        if noise_bank is not None:
            start = int(rng_k.integers(0, 65536))
            noise = noise_bank[start : start + img.size].reshape(img.shape)
            img = np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8)
        t_err = time.perf_counter() - t
        t = time.perf_counter()
        fused = acc.frame_points(d, ids, img, plan.K, plan.world_from_cam[k])
        return {
            "rgb": img,
            "ids": ids,
            "depth": d,
            "objects": np.where(rid >= OBJECT_RENDER_BASE, rid - OBJECT_RENDER_BASE, 0).astype(np.int32),
            "event": event,
            "fused": fused,
            "times": (t_render, t_err, time.perf_counter() - t),
        }

    timings.update(render=0.0, errors=0.0, fusion=0.0)
    t_loop = time.perf_counter()
    renderer.caster.cast_camera(Camera(plan.K, plan.world_from_cam[0], W, H))  # builds the BVH once, here
    with ThreadPoolExecutor(max_workers=max(1, cfg.threads)) as pool:
        for k, out in enumerate(pool.map(one_frame, range(T))):
            rgb[k], masks[k], depth[k], obj_frames[k] = out["rgb"], out["ids"], out["depth"], out["objects"]
            if out["event"] is not None:
                events.append({"kind": "drift", "frame": k, **out["event"]})
            pixel_counts += np.bincount(out["ids"].ravel(), minlength=max_id + 1)[: max_id + 1]
            acc.push(*out["fused"])
            for key, v in zip(("render", "errors", "fusion"), out["times"]):
                timings[key] += v
    timings["frames_wall"] = time.perf_counter() - t_loop

    t = time.perf_counter()
    clouds = acc.clouds()
    seen = {i for i in np.flatnonzero(pixel_counts) if i > 0}
    instances = [inst for inst in struct_instances if int(inst.id) in seen]
    gt_objects = []
    for obj in lay.objects:
        oid = obj.object_id
        ids_of = [] if oid in missed else [primary_of[oid]] + ([split_of[oid][0]] if oid in split_of else [])
        ids_of = [i for i in ids_of if i in seen]
        ids_of.sort(key=lambda i: (-len(clouds.get(i, ((),))[0]), -int(pixel_counts[i]), i))
        for i in ids_of:
            instances.append(Instance(InstanceId(i), labels.get(oid, obj.label), False))
        verts, faces = obj.model.union_mesh()
        gt_objects.append(GtObject(oid, obj.label, verts, faces, obj.world_from_object.copy(), tuple(ids_of)))
    instances.sort(key=lambda inst: int(inst.id))
    known = {int(i.id) for i in instances}
    clouds = {i: c for i, c in clouds.items() if i in known and len(c[0])}
    for i in sorted(clouds):
        pts, cols = clouds[i]
        if len(pts) > cfg.max_points_per_instance:
            keep = np.sort(
                np.random.default_rng([seed, 3, i]).choice(len(pts), cfg.max_points_per_instance, replace=False)
            )
            clouds[i] = (pts[keep], cols[keep])
    point_ids, offsets, points, colors = points_to_csr(clouds)
    relations = tuple(GtRelation(o.object_id, o.relation, o.parent, o.wall_id) for o in lay.objects)
    gt = GroundTruth(tuple(gt_objects), relations, room.shell(), tuple(s for s in structure if s.instance_id in seen))
    arrays = CaptureArrays(
        scene_id=f"synth-{cfg.name}-{seed}",
        rgb=rgb,
        K=np.tile(plan.K, (T, 1, 1)),
        world_from_cam=plan.world_from_cam.astype(np.float64),
        instance_masks=masks,
        instances=tuple(instances),
        point_ids=point_ids,
        point_offsets=offsets,
        points=points,
        colors=colors,
        depth=depth,
        source="rescene-synth",
        extra_attrs={
            "synth": {
                "preset": cfg.name,
                "seed": int(seed),
                "settings": cfg.model_dump(mode="json"),
                "frame_kinds": list(plan.kinds),
                "closeup_object": [int(v) for v in plan.target_object],
                "events": events,
            }
        },
    )
    timings["assemble"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    return SynthScene(cfg, int(seed), arrays, gt, obj_frames, plan, lay, events, timings)


def write_synth(
    path: str | Path,
    preset: str | SynthPreset = "tiny",
    seed: int = 0,
    overwrite: bool = False,
    pictures: bool = False,
    **overrides,
) -> Path:
    """Generate and write a synthetic capture (with its ``gt/`` group) at ``path``; returns the path.

    pictures: also write the contact sheet and the plan next to it (see ``picture_paths``).
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (--overwrite) or choose another path")
    scene = make_scene(preset, seed, **overrides)
    write_scene(path, scene, overwrite=overwrite, pictures=pictures)
    return path


def write_scene(
    path: str | Path, scene: SynthScene, overwrite: bool = False, pictures: bool = False
) -> dict[str, Path]:
    """Write an already generated scene; returns {"capture": path, and the pictures when written}."""
    path = Path(path)
    t = time.perf_counter()
    write_capture(
        path,
        scene.arrays,
        extra=lambda root: write_ground_truth(root, scene.gt, scene.object_id_frames),
        overwrite=overwrite,
    )
    scene.timings["write"] = time.perf_counter() - t
    out = {"capture": path}
    if pictures:
        from rescene_core.capture.synth.pictures import write_pictures

        t = time.perf_counter()
        out.update(write_pictures(path, scene))
        scene.timings["pictures"] = time.perf_counter() - t
    return out


def synth_command(out: str | Path, preset: str = "standard", seed: int = 0, overwrite: bool = False) -> int:
    """`rescene synth`: write the capture and its pictures, print what was made and where; exit code."""
    t = time.perf_counter()
    scene = make_scene(preset, seed)
    paths = write_scene(out, scene, overwrite=overwrite, pictures=True)
    elapsed = time.perf_counter() - t
    counts: dict[str, int] = {}
    for e in scene.events:
        counts[e["kind"]] = counts.get(e["kind"], 0) + 1
    a = scene.arrays
    print(
        f"wrote {paths['capture']}: {a.rgb.shape[0]} frames {a.rgb.shape[2]}x{a.rgb.shape[1]}, "
        f"{len(scene.gt.objects)} objects, {len(a.instances)} instances, {len(a.points)} points "
        f"({elapsed:.1f} s)"
    )
    print(f"panoptic errors: {', '.join(f'{k} {v}' for k, v in sorted(counts.items())) or 'none'}")
    for key, p in paths.items():
        if key != "capture":
            print(f"{key}: {p}")
    return 0
