"""Test doubles for the stage libraries, substituted into ``rescene_core.stages.calls`` by monkeypatching.

They exist only to test the harness (caching, retries, fan-out, run log, export) independently of the
stages; each one counts its calls in ``CALLS`` so tests can check what executed. Also a small hand-made
capture with a few box objects, for when the synthetic generator is not wanted.
"""

from __future__ import annotations

import threading
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from rescene_core.capture import CaptureArrays, points_to_csr, write_capture
from rescene_core.hierview import KeyFrames
from rescene_core.io import write_json_atomic
from rescene_core.records import (
    Asset,
    Edge,
    Instance,
    InstanceId,
    Layout,
    Missing,
    Operation,
    Plane,
    Pose,
    Relation,
    RoomShell,
    Root,
    SceneGraph,
    ViewChoice,
    WallPlane,
)

CALLS: Counter = Counter()
_LOCK = threading.Lock()


def _count(name: str) -> None:
    with _LOCK:
        CALLS[name] += 1


def box_capture(path: Path, objects: int = 3, frames: int = 3, size: tuple[int, int] = (40, 30)) -> Path:
    """A capture of ``objects`` axis-aligned boxes on a floor (instance 1 = floor, objects 2..)."""
    rng = np.random.default_rng(0)
    w, h = size
    K = np.tile(np.array([[30.0, 0, w / 2], [0, 30.0, h / 2], [0, 0, 1]]), (frames, 1, 1))
    poses = np.tile(np.eye(4), (frames, 1, 1))
    poses[:, 0, 3] = np.arange(frames) * 0.1
    masks = np.zeros((frames, h, w), np.int32)
    masks[:, h - 5 :, :] = 1
    clouds = {1: (rng.uniform([-2, -2, 0], [2, 2, 0.001], (200, 3)), np.full((200, 3), 128, np.uint8))}
    instances = [Instance(InstanceId(1), "floor", True)]
    for k in range(objects):
        i = k + 2
        lo = np.array([k * 1.0 - 1.0, 0.0, 0.0])
        pts = lo + rng.uniform(0, [0.5, 0.4, 0.6], (100, 3))
        clouds[i] = (pts, rng.integers(0, 255, (100, 3), dtype=np.uint8))
        masks[:, 5:15, 2 + 10 * k : 8 + 10 * k] = i
        instances.append(Instance(InstanceId(i), "box"))
    ids, offsets, pts, cols = points_to_csr(clouds)
    arrays = CaptureArrays(
        scene_id="boxes",
        rgb=rng.integers(0, 255, (frames, h, w, 3), dtype=np.uint8),
        K=K,
        world_from_cam=poses,
        instance_masks=masks,
        instances=tuple(instances),
        point_ids=ids,
        point_offsets=offsets,
        points=pts,
        colors=cols,
        depth=np.full((frames, h, w), 2.0, np.float32),
        source="test",
    )
    return write_capture(path, arrays)


def estimate_shell(capture, config):
    _count("shell")
    return RoomShell(
        floor=Plane((0.0, 0.0, 1.0), 0.0),
        walls=(WallPlane(0, Plane((0.0, 1.0, 0.0), 2.0), ((-2.0, -2.0), (2.0, -2.0))),),
        floor_polygon=((-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)),
    )


def select_views(capture, config, instance_ids):
    _count("view")
    out: dict[int, ViewChoice | Missing] = {}
    for i in instance_ids:
        if len(capture.point_cloud(i)) == 0:
            out[i] = Missing(InstanceId(i), "view", "no points")
        else:
            out[i] = ViewChoice(InstanceId(i), 0, "fake", "first frame", ({"frame": 0, "area": 1.0},))
    return out


def select_keyframes(capture, config):
    _count("keyframes")
    frames = (0, capture.num_frames - 1)
    n = capture.num_frames
    return KeyFrames(frames, (1, 1), 0.05, False, tuple(range(n)), 2, 2, 2, (1.0,) * n, (0,) * n)


def generate_asset(capture, view, config):
    _count("asset")
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    return Asset(view.instance, np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64), "fake")


def save_asset(path, asset) -> None:
    Path(path).write_bytes(trimesh.Trimesh(asset.vertices, asset.faces, process=False).export(file_type="glb"))


def load_asset(path, instance):
    mesh = trimesh.load(path, force="mesh", process=False)
    return Asset(instance, np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64), "fake")


def register(asset, target, config):
    _count("registration")
    pts = np.asarray(target.points, np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    m = np.eye(4)
    s = float(np.max(hi - lo)) * config.scale_max
    m[:3, :3] *= s
    m[:3, 3] = (lo + hi) / 2
    return Pose(asset.instance, m, "fake", {"rmse": 0.01, "inlier_ratio": 0.9})


def make_predictor(config):
    return "fake-predictor"


@dataclass(frozen=True)
class FakePrediction:
    frame: int
    visible: tuple[int, ...]

    def to_json(self) -> dict[str, Any]:
        return {"frame": self.frame, "visible": list(self.visible)}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> FakePrediction:
        return cls(int(d["frame"]), tuple(d["visible"]))


def predict_frame(capture, frame, shell, config, predictor):
    _count("relations")
    ids = np.unique(np.asarray(capture.instance_masks[frame]))
    return FakePrediction(int(frame), tuple(int(i) for i in ids if i > 1))


def frame_prediction_from_json(data):
    return FakePrediction.from_json(data)


def fuse(predictions, capture, shell, config, missing):
    _count("fusion")
    seen = sorted({i for p in predictions for i in p.visible} - set(missing))
    return SceneGraph(tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR, 0.9) for i in seen))


def fuse_with_report(predictions, capture, shell, config, missing, predictor):
    return fuse(predictions, capture, shell, config, missing), None


def write_frame(out_dir, capture, prediction, config):
    write_json_atomic(Path(out_dir) / "frames" / f"{prediction.frame}.json", prediction.to_json())


def write_graph(out_dir, graph, capture, shell, report):
    return write_json_atomic(Path(out_dir) / "graph.json", graph.to_json())


@dataclass(frozen=True)
class FakeAssemblyObject:
    instance: int
    label: str
    vertices: np.ndarray
    faces: np.ndarray
    world_from_asset: np.ndarray
    points: np.ndarray | None = None


def assembly_object(instance, label, vertices, faces, world_from_asset, points=None):
    return FakeAssemblyObject(instance, label, vertices, faces, world_from_asset, points)


def attach(objects, graph, shell, config):
    _count("attachment")
    poses = {}
    ops = []
    for i, obj in objects.items():
        # the attachment task hands the solver each object's observed points as evidence
        assert obj.points is not None and obj.points.shape[1:] == (3,), f"instance {i} reached attach without points"
        m = np.array(obj.world_from_asset, dtype=np.float64)
        lowest = (obj.vertices @ m[:3, :3].T + m[:3, 3])[:, 2].min()
        m[2, 3] -= lowest
        poses[i] = m
        ops.append(Operation(int(i), "all", "floor snap", "floor-snap", {"dz": float(-lowest)}))
    return Layout(poses, tuple(ops))


STAGE_FAKES = {
    "estimate_shell": estimate_shell,
    "select_views": select_views,
    "select_keyframes": select_keyframes,
    "generate_asset": generate_asset,
    "save_asset": save_asset,
    "load_asset": load_asset,
    "register": register,
    "make_predictor": make_predictor,
    "predict_frame": predict_frame,
    "frame_prediction_from_json": frame_prediction_from_json,
    "fuse": fuse,
    "fuse_with_report": fuse_with_report,
    "write_frame": write_frame,
    "write_graph": write_graph,
    "assembly_object": assembly_object,
    "attach": attach,
}
