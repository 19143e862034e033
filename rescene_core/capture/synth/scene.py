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
from rescene_core.capture.synth.builder import WOODS
from rescene_core.capture.synth.cameras import CameraPlan, plan_cameras
from rescene_core.capture.synth.layout import Layout, Room, furnish, random_room
from rescene_core.capture.synth.panoptic import (
    OBJECT_RENDER_BASE,
    Accumulator,
    PanopticPlan,
    boundary_noise,
    depth_with_noise,
    drift,
    plan_panoptic_errors,
)
from rescene_core.capture.synth.pictures import write_pictures
from rescene_core.capture.synth.presets import SynthPreset, get_preset
from rescene_core.records import Camera, Instance, InstanceId
from rescene_core.render import Light, Renderer, RenderMesh, Shading, Texture


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
    Steps: layout and cameras, the render scene, the panoptic model's per-object errors
    (``panoptic.plan_panoptic_errors``), the frames (render, per-frame errors, fusion), the capture.
    """
    cfg = get_preset(preset, **overrides)
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    root_rng = np.random.default_rng(seed)
    seed_seq = root_rng.bit_generator.seed_seq
    assert isinstance(seed_seq, np.random.SeedSequence)  # default_rng(int) seeds with a SeedSequence
    rngs = [np.random.default_rng(s) for s in seed_seq.spawn(6)]
    rng_layout, rng_cam, rng_look, rng_err, _rng_frames, rng_ids = rngs
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

    errors = plan_panoptic_errors(lay.objects, len(struct_instances), cfg, rng_err, rng_ids)
    lut = errors.render_lut([s.instance_id for s in structure], lay.objects)
    frames = _render_frames(renderer, plan, lay, errors, lut, cfg, seed, timings)

    t = time.perf_counter()
    arrays, gt = _assemble(cfg, seed, room, lay, plan, structure, struct_instances, errors, frames)
    timings["assemble"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    return SynthScene(cfg, int(seed), arrays, gt, frames.objects, plan, lay, errors.events, timings)


@dataclass
class _Frames:
    """The rendered frames with the panoptic errors applied, and the fused instance points.

    rgb uint8 [T, H, W, 3], masks int32 [T, H, W] (reported instance ids), depth float32 [T, H, W],
    objects int32 [T, H, W] (error-free object id, 0 = structure or nothing), pixel_counts int64 [max_id + 1]
    (pixels per reported id over all frames), fusion: the per-instance voxel accumulator.
    """

    rgb: NDArray[np.uint8]
    masks: NDArray[np.int32]
    depth: NDArray[np.float32]
    objects: NDArray[np.int32]
    pixel_counts: NDArray[np.int64]
    fusion: Accumulator


def _voxel_sizes(lay: Layout, errors: PanopticPlan, cfg: SynthPreset) -> NDArray[np.float64]:
    """Fusion voxel size (m) per instance id [next_id + 1]: the structure's, or a fraction of the object's size."""
    voxel_of = np.full(errors.next_id + 1, cfg.structure_voxel)
    for obj in lay.objects:
        vox = float(np.clip(np.linalg.norm(obj.model.size) * cfg.object_voxel_ratio, *cfg.object_voxel_range))
        voxel_of[errors.primary_of[obj.object_id]] = vox
        if obj.object_id in errors.split_of:
            voxel_of[errors.split_of[obj.object_id][0]] = vox
    return voxel_of


def _render_frames(
    renderer: Renderer,
    plan: CameraPlan,
    lay: Layout,
    errors: PanopticPlan,
    lut: NDArray[np.int32],
    cfg: SynthPreset,
    seed: int,
    timings: dict[str, float],
) -> _Frames:
    """Render every frame, apply the splits and the per-frame errors (boundary noise, drift, depth noise,
    RGB noise), fuse the points; drift events are appended to ``errors.events`` in frame order."""
    object_instance_ids = errors.object_instance_ids()
    local_from_world = {oid: np.linalg.inv(lay.objects[oid - 1].world_from_object) for oid in errors.split_of}
    T, H, W = cfg.frames, cfg.height, cfg.width
    max_id = errors.next_id
    out = _Frames(
        np.zeros((T, H, W, 3), np.uint8),
        np.zeros((T, H, W), np.int32),
        np.zeros((T, H, W), np.float32),
        np.zeros((T, H, W), np.int32),
        np.zeros(max_id + 1, np.int64),
        Accumulator(_voxel_sizes(lay, errors, cfg), cfg.fusion_stride),
    )
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
        errors.apply_splits(rid, ids, frame.hits.points, local_from_world)
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
        fused = out.fusion.frame_points(d, ids, img, plan.K, plan.world_from_cam[k])
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
        for k, frame_out in enumerate(pool.map(one_frame, range(T))):
            out.rgb[k], out.masks[k] = frame_out["rgb"], frame_out["ids"]
            out.depth[k], out.objects[k] = frame_out["depth"], frame_out["objects"]
            if frame_out["event"] is not None:
                errors.events.append({"kind": "drift", "frame": k, **frame_out["event"]})
            out.pixel_counts += np.bincount(frame_out["ids"].ravel(), minlength=max_id + 1)[: max_id + 1]
            out.fusion.push(*frame_out["fused"])
            for key, v in zip(("render", "errors", "fusion"), frame_out["times"]):
                timings[key] += v
    timings["frames_wall"] = time.perf_counter() - t_loop
    return out


def _assemble(
    cfg: SynthPreset,
    seed: int,
    room: Room,
    lay: Layout,
    plan: CameraPlan,
    structure: list[GtStructure],
    struct_instances: list[Instance],
    errors: PanopticPlan,
    frames: _Frames,
) -> tuple[CaptureArrays, GroundTruth]:
    """The capture arrays (instances seen in some frame, their clouds capped at ``max_points_per_instance``)
    and the ground truth (objects with the instance ids reported for them, largest cloud first)."""
    clouds = frames.fusion.clouds()
    pixel_counts = frames.pixel_counts
    seen = {i for i in np.flatnonzero(pixel_counts) if i > 0}
    instances = [inst for inst in struct_instances if int(inst.id) in seen]
    gt_objects = []
    for obj in lay.objects:
        oid = obj.object_id
        ids_of = [i for i in errors.instances_of(oid) if i in seen]
        ids_of.sort(key=lambda i: (-len(clouds.get(i, ((),))[0]), -int(pixel_counts[i]), i))
        for i in ids_of:
            instances.append(Instance(InstanceId(i), errors.labels.get(oid, obj.label), False))
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
    T = cfg.frames
    arrays = CaptureArrays(
        scene_id=f"synth-{cfg.name}-{seed}",
        rgb=frames.rgb,
        K=np.tile(plan.K, (T, 1, 1)),
        world_from_cam=plan.world_from_cam.astype(np.float64),
        instance_masks=frames.masks,
        instances=tuple(instances),
        point_ids=point_ids,
        point_offsets=offsets,
        points=points,
        colors=colors,
        depth=frames.depth,
        source="rescene-synth",
        extra_attrs={
            "synth": {
                "preset": cfg.name,
                "seed": int(seed),
                "settings": cfg.settings(),
                "frame_kinds": list(plan.kinds),
                "closeup_object": [int(v) for v in plan.target_object],
                "events": errors.events,
            }
        },
    )
    return arrays, gt


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
        t = time.perf_counter()
        out.update(write_pictures(path, scene))
        scene.timings["pictures"] = time.perf_counter() - t
    return out
