"""Write a capture out in each source layout the importers read (rgbd, panoptic, scannet, nerfstudio).

For round-trip tests and the ``import`` benchmark: a synthetic capture written here and imported back must
give the same poses, intrinsics, masks and depth (depth to the millimetre of the uint16 encoding).

source_from_world: an optional rigid transform applied to the poses on the way out, to play a recorder
whose world is not z up (e.g. y up like a HoloLens).
"""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image

from rescene_core.capture.format import Capture, CaptureArrays
from rescene_core.capture.importers.common import OPENGL_FROM_OPENCV

Y_UP_FROM_Z_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])
"""A recorder world with y up: (x, y, z)_z-up -> (x, z, -y)."""


def _depth_png(depth: NDArray[np.float32]) -> Image.Image:
    mm = np.clip(np.round(np.asarray(depth, np.float64) * 1000.0), 0, 65535).astype(np.uint16)
    return Image.fromarray(mm)


def _ids_png(ids: NDArray) -> Image.Image:
    ids = np.asarray(ids)
    if ids.max(initial=0) > 65535:
        raise ValueError("instance ids above 65535 do not fit a uint16 PNG")
    return Image.fromarray(ids.astype(np.uint16))


def _poses(arrays: CaptureArrays | Capture, source_from_world: NDArray | None) -> NDArray[np.float64]:
    poses = np.asarray(arrays.world_from_cam, np.float64)
    if source_from_world is not None:
        poses = np.einsum("ij,tjk->tik", np.asarray(source_from_world, np.float64), poses)
    return poses


def _labels(arrays: CaptureArrays) -> list[dict]:
    return [inst.to_json() for inst in arrays.instances]


def write_rgbd(arrays: CaptureArrays, dest: str | Path, source_from_world: NDArray | None = None) -> Path:
    """images/NNNNN.png, depth/NNNNN.png (uint16 mm), poses.txt, K.txt (the first frame's K)."""
    dest = Path(dest)
    (dest / "images").mkdir(parents=True, exist_ok=True)
    (dest / "depth").mkdir(parents=True, exist_ok=True)
    if arrays.depth is None:
        raise ValueError("the rgbd layout needs depth")
    for t in range(len(arrays.rgb)):
        Image.fromarray(np.asarray(arrays.rgb[t])).save(dest / "images" / f"{t:05d}.png")
        _depth_png(arrays.depth[t]).save(dest / "depth" / f"{t:05d}.png")
    poses = _poses(arrays, source_from_world)
    np.savetxt(dest / "poses.txt", poses.reshape(len(poses), 16), fmt="%.17g")
    np.savetxt(dest / "K.txt", np.asarray(arrays.K[0]), fmt="%.17g")
    return dest


def write_panoptic(arrays: CaptureArrays, dest: str | Path, source_from_world: NDArray | None = None) -> Path:
    """The rgbd layout plus instances/NNNNN.png (uint16 ids) and labels.json."""
    dest = write_rgbd(arrays, dest, source_from_world)
    (dest / "instances").mkdir(exist_ok=True)
    for t in range(len(arrays.rgb)):
        _ids_png(arrays.instance_masks[t]).save(dest / "instances" / f"{t:05d}.png")
    (dest / "labels.json").write_text(json.dumps(_labels(arrays), indent=1))
    return dest


def write_nerfstudio(arrays: CaptureArrays, dest: str | Path, source_from_world: NDArray | None = None) -> Path:
    """transforms.json (OpenGL camera axes, shared intrinsics), images/, depth/ (uint16 mm)."""
    dest = Path(dest)
    (dest / "images").mkdir(parents=True, exist_ok=True)
    (dest / "depth").mkdir(parents=True, exist_ok=True)
    poses = _poses(arrays, source_from_world)
    K = np.asarray(arrays.K[0])
    h, w = arrays.rgb.shape[1:3]
    frames = []
    for t in range(len(arrays.rgb)):
        Image.fromarray(np.asarray(arrays.rgb[t])).save(dest / "images" / f"frame_{t + 1:05d}.png")
        _depth_png(arrays.depth[t]).save(dest / "depth" / f"frame_{t + 1:05d}.png")
        frames.append(
            {
                "file_path": f"images/frame_{t + 1:05d}.png",
                "depth_file_path": f"depth/frame_{t + 1:05d}.png",
                "transform_matrix": (poses[t] @ OPENGL_FROM_OPENCV).tolist(),
            }
        )
    meta = {
        "camera_model": "OPENCV",
        "fl_x": float(K[0, 0]), "fl_y": float(K[1, 1]), "cx": float(K[0, 2]), "cy": float(K[1, 2]),
        "w": int(w), "h": int(h), "depth_unit_scale_factor": 0.001, "frames": frames,
    }  # fmt: skip
    (dest / "transforms.json").write_text(json.dumps(meta, indent=1))
    return dest


SCANNET_LABEL_TSV_HEADER = "id\traw_category\tcategory\tcount\tnyu40id\tnyu40class"


def write_scannet(
    arrays: CaptureArrays | Capture,
    dest: str | Path,
    source_from_world: NDArray | None = None,
    color_scale: int = 2,
    inf_pose_frames: tuple[int, ...] = (),
    threads: int = 2,
) -> Path:
    """A ScanNet reader export: color/N.jpg (``color_scale`` x the depth size), depth/N.png (uint16 mm),
    pose/N.txt, intrinsic/intrinsic_{color,depth}.txt (4x4), instance-filt/N.png, label-filt/N.png and a
    label map TSV. inf_pose_frames: frames whose pose is written as all -inf, as ScanNet does.

    ``arrays`` may be an opened capture: its frames are read one at a time (a long scan is never held in
    memory) and encoded on ``threads`` threads."""
    dest = Path(dest)
    depth = arrays.depth
    if depth is None:
        raise ValueError("the scannet layout needs depth")
    for sub in ("color", "depth", "pose", "intrinsic", "instance-filt", "label-filt"):
        (dest / sub).mkdir(parents=True, exist_ok=True)
    poses = _poses(arrays, source_from_world)
    names = sorted({inst.label for inst in arrays.instances})
    label_id = {name: k + 1 for k, name in enumerate(names)}
    lut = np.zeros(max((int(inst.id) for inst in arrays.instances), default=0) + 1, np.int64)
    for inst in arrays.instances:
        lut[int(inst.id)] = label_id[inst.label]
    h, w = arrays.rgb.shape[1:3]

    def frame(t: int) -> None:
        rgb = Image.fromarray(np.asarray(arrays.rgb[t]))
        if color_scale != 1:
            rgb = rgb.resize((w * color_scale, h * color_scale), Image.Resampling.BILINEAR)
        rgb.save(dest / "color" / f"{t}.jpg", quality=95)
        _depth_png(np.asarray(depth[t])).save(dest / "depth" / f"{t}.png")
        pose = np.full((4, 4), -np.inf) if t in inf_pose_frames else poses[t]
        np.savetxt(dest / "pose" / f"{t}.txt", pose, fmt="%.17g")
        ids = np.asarray(arrays.instance_masks[t])
        _ids_png(ids).save(dest / "instance-filt" / f"{t}.png")
        labels = np.where(ids < len(lut), lut[np.minimum(ids, len(lut) - 1)], 0)  # ids without a record: 0
        _ids_png(labels).save(dest / "label-filt" / f"{t}.png")

    if threads > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(frame, range(arrays.rgb.shape[0])))
    else:
        for t in range(arrays.rgb.shape[0]):
            frame(t)
    K4 = np.eye(4)
    K4[:3, :3] = np.asarray(arrays.K[0])
    np.savetxt(dest / "intrinsic" / "intrinsic_depth.txt", K4, fmt="%.17g")
    Kc = K4.copy()
    Kc[:2] *= color_scale
    np.savetxt(dest / "intrinsic" / "intrinsic_color.txt", Kc, fmt="%.17g")
    rows = [SCANNET_LABEL_TSV_HEADER] + [f"{label_id[n]}\t{n}\t{n}\t1\t0\t{n}" for n in names]
    (dest / "scannetv2-labels.combined.tsv").write_text("\n".join(rows) + "\n")
    return dest


WRITERS = {"rgbd": write_rgbd, "panoptic": write_panoptic, "nerfstudio": write_nerfstudio, "scannet": write_scannet}
"""Layout name -> writer ``(arrays, dest, source_from_world=None) -> dest``."""


def write_scannet_mesh_annotation(scene, dest: str | Path, name: str = "scene0000_00") -> dict[int, int]:
    """ScanNet's 3D annotation of a synthetic scene: ``<name>_vh_clean_2.ply`` (the objects' meshes and a
    floor), ``<name>.aggregation.json`` and ``<name>_vh_clean_2.0.010000.segs.json``. One segment per
    object; objectId = instance id - 1. Returns {ground-truth object id: instance id}."""

    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    verts, faces, seg_idx, groups, by_object = [], [], [], [], {}
    off = 0
    for o in scene.gt.objects:
        if not o.instance_ids:
            continue
        iid = int(o.instance_ids[0])
        v = o.world_vertices()
        verts.append(v)
        faces.append(np.asarray(o.faces) + off)
        seg_idx += [iid] * len(v)
        groups.append({"id": iid - 1, "objectId": iid - 1, "label": o.label, "segments": [iid]})
        by_object[int(o.object_id)] = iid
        off += len(v)
    x0, y0, x1, y1 = (
        np.asarray(scene.gt.shell.floor_polygon).min(0).tolist()
        + np.asarray(scene.gt.shell.floor_polygon).max(0).tolist()
    )
    floor_id = max(by_object.values(), default=0) + 1
    verts.append(np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]))
    faces.append(np.array([[0, 1, 2], [0, 2, 3]]) + off)
    seg_idx += [floor_id] * 4
    groups.append({"id": floor_id - 1, "objectId": floor_id - 1, "label": "floor", "segments": [floor_id]})
    mesh = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    mesh.export(dest / f"{name}_vh_clean_2.ply")
    (dest / f"{name}.aggregation.json").write_text(json.dumps({"sceneId": name, "segGroups": groups}))
    (dest / f"{name}_vh_clean_2.0.010000.segs.json").write_text(json.dumps({"segIndices": seg_idx}))
    return by_object
