"""Adapter to SAM 3D Objects (facebookresearch/sam-3d-objects) for GPU workers.

Public inference API (the repository's ``notebook/inference.py``)::

    inference = Inference("<checkpoints>/pipeline.yaml", compile=False)
    output = inference(image_rgb_uint8, mask_bool, seed=42)       # dict

with, per the repository's visualisation code (``SceneVisualizer.object_pointcloud`` / ``make_scene``):
``output["glb"]`` a trimesh mesh of the object, ``output["rotation"]`` a [1, 4] quaternion (w, x, y, z),
``output["translation"]`` [1, 3] and ``output["scale"]`` [1, 3] (isotropic), which place the object's
local points in the PyTorch3D camera frame with row vectors: ``p_cam = (s * p_local) @ R + t``,
``R = quaternion_to_matrix(q)``. PyTorch3D cameras have x left, y up, z forward; OpenCV's (ours) x
right, y down, z forward. The exported GLB is y-up (glTF); the local frame is z-up, related by
``GLB_FROM_LOCAL`` (a -90 deg turn about x, as the repository's own y-up/z-up fix uses).

This module imports nothing heavy at import time; ``Sam3dBackend`` loads ``notebook/inference.py`` by
its path (``load_inference``: the clone ``assets.sam3d_code_dir`` names, else the clone the installed
``sam3d_objects`` package lives in; ``sys.path`` is left alone) only when it is constructed, and says
which install or checkpoint is missing. The model was not run in this
project's tests (no weights, no GPU); ``convert_output`` is tested on fake outputs of the documented
shape. docs/backends.md says what was and was not run.
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from rescene_core.assets.base import BackendUnavailable, GenerationFailed, GeneratorInput, GeneratorOutput
from rescene_core.config import AssetConfig
from rescene_core.geometry import sim3
from rescene_core.ops.devices import module_device, note_device
from rescene_core.records import Asset, Camera, Pose

GLB_FROM_LOCAL = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""Rotation from SAM 3D's z-up local object frame to its y-up GLB export (y_glb = z, z_glb = -y)."""

CV_FROM_PYTORCH3D = np.diag([-1.0, -1.0, 1.0])
"""PyTorch3D camera axes (x left, y up, z forward) to OpenCV's (x right, y down, z forward)."""


def _array(value: Any) -> NDArray[np.float64]:
    """A tensor (torch, on any device) or array-like as float64 numpy."""
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return np.asarray(value, dtype=np.float64)


def camera_from_local(output: dict[str, Any]) -> sim3.Matrix4:
    """cam_from_local (OpenCV camera axes) of a SAM 3D output's rotation / translation / scale."""
    quat_wxyz = _array(output["rotation"]).reshape(-1)[:4]
    trans = _array(output["translation"]).reshape(-1)[:3]
    scales = _array(output["scale"]).reshape(-1)
    if not np.allclose(scales, scales[0], rtol=1e-4):
        raise GenerationFailed(f"SAM 3D scale is not isotropic: {scales.tolist()}")
    rot_rows = Rotation.from_quat([quat_wxyz[1], quat_wxyz[2], quat_wxyz[3], quat_wxyz[0]]).as_matrix()
    # row-vector p @ R is column-vector R^T p
    p3d_from_local = sim3.sim3_from_parts(float(scales[0]), rot_rows.T, trans)
    cv = np.eye(4)
    cv[:3, :3] = CV_FROM_PYTORCH3D
    return cv @ p3d_from_local


def convert_output(output: dict[str, Any], camera: Camera) -> GeneratorOutput:
    """A SAM 3D Objects output dict -> GeneratorOutput in its local (z-up) frame, with the world prior.

    The prior ``world_from_generator`` = world_from_cam * cam_from_local is what the generator's layout
    head predicts; registration uses it as its rotation-gate reference.
    """
    mesh = output.get("glb")
    if mesh is None or not hasattr(mesh, "vertices"):
        raise GenerationFailed("SAM 3D output has no 'glb' mesh")
    if hasattr(mesh, "to_geometry"):  # a trimesh Scene
        mesh = mesh.to_geometry()
    glb_vertices = np.asarray(mesh.vertices, dtype=np.float64)
    local = glb_vertices @ GLB_FROM_LOCAL  # (GLB_FROM_LOCAL^T p_glb) row-wise
    world_from_local = sim3.compose(camera.world_from_cam, camera_from_local(output))
    metadata = {
        "model": "SAM 3D Objects",
        "glb_vertices": int(len(glb_vertices)),
        "layout": {
            "rotation_wxyz": _array(output["rotation"]).reshape(-1)[:4].tolist(),
            "translation": _array(output["translation"]).reshape(-1)[:3].tolist(),
            "scale": float(_array(output["scale"]).reshape(-1)[0]),
        },
    }
    return GeneratorOutput(local, np.asarray(mesh.faces, dtype=np.int64), metadata, world_from_local)


def layout_pose(asset: Asset) -> Pose | None:
    """The generator's own placement of a SAM 3D asset as a Pose (method 'sam3d_layout'), when it has one.

    world_from_asset = world_from_cam * cam_from_local * generator_from_asset; registration refines it.
    """
    prior = asset.metadata.get("world_from_asset_prior")
    if prior is None:
        return None
    return Pose(asset.instance, np.asarray(prior, dtype=np.float64), "sam3d_layout", {"source": "SAM 3D layout"})


def inference_path(code_dir: str | None) -> Path:
    """The repository's ``notebook/inference.py``: under ``code_dir`` when given, else beside the installed
    ``sam3d_objects`` package (an editable install of the clone). Raises BackendUnavailable naming the fix."""
    if code_dir:
        path = Path(code_dir).expanduser() / "notebook" / "inference.py"
    else:
        spec = importlib.util.find_spec("sam3d_objects")
        if spec is None or spec.origin is None:
            raise BackendUnavailable(
                "the sam3d backend needs SAM 3D Objects installed on this worker (pip install -e the "
                "sam-3d-objects clone with its inference extras) and assets.sam3d_code_dir set to the clone"
            )
        path = Path(spec.origin).resolve().parent.parent / "notebook" / "inference.py"
    if not path.is_file():
        raise BackendUnavailable(
            f"SAM 3D Objects' notebook/inference.py not found at {path}; set assets.sam3d_code_dir to the "
            "sam-3d-objects clone"
        )
    return path


@functools.cache
def load_inference(path: Path) -> type:
    """The ``Inference`` class of SAM 3D Objects' ``notebook/inference.py``, loaded by path as its own module
    (the notebook folder is not a package; ``sys.path`` is not touched). BackendUnavailable when its imports
    (``sam3d_objects``, torch, pytorch3d, ...) are not installed."""
    spec = importlib.util.spec_from_file_location("rescene_sam3d_inference", path)
    if spec is None or spec.loader is None:
        raise BackendUnavailable(f"cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except ImportError as err:
        raise BackendUnavailable(
            f"{path} needs SAM 3D Objects installed on this worker (pip install -e the sam-3d-objects clone "
            f"with its inference extras): {err}"
        ) from err
    inference = getattr(module, "Inference", None)
    if not isinstance(inference, type):
        raise BackendUnavailable(f"{path} defines no Inference class (an unexpected sam-3d-objects version)")
    return inference


@functools.lru_cache(maxsize=2)
def _inference(config_path: str, code_dir: str | None, mtime: float):
    """SAM 3D Objects' pipeline, loaded once per process, checkpoint config and its mtime: every instance,
    task and flow run of a worker reuses the loaded model (its Inference puts it on the GPU)."""
    inference_cls = load_inference(inference_path(code_dir))
    return inference_cls(config_path, compile=False)


def inference_device(inference: object) -> str:
    """Where SAM 3D Objects' ``Inference`` put its pipeline: its own ``device``, its pipeline's, or the device
    of the first torch module it holds; "unknown" when it shows none (its ``Inference`` places the model)."""
    for holder in (inference, getattr(inference, "_pipeline", None), getattr(inference, "pipeline", None)):
        device = getattr(holder, "device", None)
        if device is not None:
            return str(device)
    for value in vars(inference).values() if hasattr(inference, "__dict__") else ():
        if callable(getattr(value, "parameters", None)):
            return module_device(value)
    return "unknown"


class Sam3dBackend:
    """SAM 3D Objects behind the AssetBackend protocol (GPU worker with SAM 3D Objects installed)."""

    name = "sam3d"

    def __init__(self, config: AssetConfig):
        checkpoint = config.sam3d_checkpoint
        if not checkpoint:
            raise BackendUnavailable(
                "the sam3d backend needs assets.sam3d_checkpoint: the path of SAM 3D Objects' "
                "checkpoints/<tag>/pipeline.yaml (weights are never downloaded)"
            )
        config_path = Path(checkpoint)
        if config_path.is_dir():
            config_path = config_path / "pipeline.yaml"
        if not config_path.is_file():
            raise BackendUnavailable(f"SAM 3D Objects pipeline config not found at {config_path}")
        self.seed = config.seed
        self.inference = _inference(str(config_path.resolve()), config.sam3d_code_dir, config_path.stat().st_mtime)
        self.device = inference_device(self.inference)

    def generate(self, view: GeneratorInput) -> GeneratorOutput:
        note_device(self.name, self.device)
        output = self.inference(np.asarray(view.rgb), np.asarray(view.mask, bool), seed=self.seed)
        out = convert_output(output, view.camera)
        out.metadata.update({"frame": int(view.frame), "label": view.label, "seed": self.seed})
        return out
