"""Rendering fidelity: the assembled scene rendered from the capture's cameras that were not key frames,
compared with the captured frames.

Rendering: the project's ray caster (``rescene_core.render.Renderer``), flat shading (ambient 1, no
lights, gamma 1) so that a surface shows its albedo. Generated assets carry no colour, so each object's
albedo is the mean colour of its capture instance points, and the floor and walls take the mean colour
of the capture's floor and wall instances (grey when absent): the comparison measures where things are
and how they cover the image, not texture.

Metrics (images scaled by ``RenderingConfig.scale``; the capture's masks and depth resized with nearest):
- depth over pixels valid in both (captured depth > 0 and a rendered hit): AbsRel = mean |r - c| / c,
  RMSE (m), delta < 1.25 = fraction with max(r / c, c / r) < 1.25; coverage = such pixels / valid captured;
- instance-mask IoU per object over all evaluated frames (rendered id == instance vs captured mask ==
  instance), and its mean over placed objects and over every object instance of the capture (unplaced = 0);
- PSNR (dB, capped at ``psnr_cap``) and SSIM (scikit-image ``structural_similarity``, Gaussian weights,
  sigma 1.5, no sample covariance, data_range 255) of RGB, per frame over the pixels of captured object
  masks (masked; SSIM is the mean of the SSIM map over the mask) and over the whole frame, then averaged
  over frames;
- LPIPS (the ``lpips`` package) only from a local weights file (``lpips_weights``); otherwise "not run".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray
from PIL import Image
from pydantic import BaseModel, ConfigDict

from rescene_core.evaluation.geometry import scaled_camera
from rescene_core.records import Camera
from rescene_core.render import Renderer, RenderMesh, Shading, Texture


class RenderingConfig(BaseModel):
    """Frames, image scale and metric settings of the rendering comparison."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    scale: float = 0.5
    """Image scale of the comparison (1 = capture resolution)."""
    frame_stride: int = 1
    """Evaluate every n-th non-key frame."""
    delta: float = 1.25
    """Depth accuracy threshold: max(r / c, c / r) below this."""
    psnr_cap: float = 100.0
    """PSNR of identical images (infinite) is reported as this (dB)."""
    ssim_sigma: float = 1.5
    """Gaussian sigma of SSIM (pixels)."""
    lpips_weights: str | None = None
    """Local path of LPIPS weights (a state dict of ``lpips.LPIPS``); None: LPIPS is not run."""
    lpips_net: str = "alex"
    """LPIPS backbone of those weights ('alex', 'vgg' or 'squeeze')."""


def psnr(a: NDArray, b: NDArray, mask: NDArray[np.bool_] | None = None, cap: float = 100.0) -> float | None:
    """PSNR (dB) of two uint8 images [H, W, 3] over ``mask`` [H, W] (all pixels when None); None when the
    mask is empty; ``cap`` for identical pixels."""
    diff = a.astype(np.float64) - b.astype(np.float64)
    if mask is not None:
        diff = diff[mask]
    if diff.size == 0:
        return None
    mse = float(np.mean(diff**2))
    return cap if mse == 0 else min(cap, 10.0 * np.log10(255.0**2 / mse))


def ssim(
    a: NDArray, b: NDArray, mask: NDArray[np.bool_] | None = None, sigma: float = 1.5
) -> tuple[float, float | None]:
    """(SSIM of the whole image, mean of the SSIM map over ``mask``) of two uint8 images [H, W, 3]:
    scikit-image, Gaussian weights, no sample covariance, data_range 255."""
    from skimage.metrics import structural_similarity

    full, smap = structural_similarity(
        a,
        b,
        channel_axis=2,
        gaussian_weights=True,
        sigma=sigma,
        use_sample_covariance=False,
        data_range=255,
        full=True,
    )
    masked = None if mask is None or not mask.any() else float(smap[mask].mean())
    return float(full), masked


def _resize(image: NDArray, size: tuple[int, int], nearest: bool) -> NDArray:

    if (image.shape[1], image.shape[0]) == size:
        return np.asarray(image)
    mode = Image.Resampling.NEAREST if nearest else Image.Resampling.BILINEAR
    return np.asarray(Image.fromarray(np.ascontiguousarray(image)).resize(size, mode))


def _mean_color(capture: Any, ids: Sequence[int]) -> tuple[float, float, float] | None:
    cols = [np.asarray(capture.point_cloud(int(i)).colors, np.float64) for i in ids]
    cols = [c for c in cols if len(c)]
    if not cols:
        return None
    m = np.concatenate(cols).mean(0) / 255.0
    return float(m[0]), float(m[1]), float(m[2])


def scene_render_meshes(
    placed: Mapping[int, tuple[str, trimesh.Trimesh]], shell: Mapping[str, trimesh.Trimesh], capture: Any
):
    """RenderMeshes of the placed objects (id = instance id, albedo = mean instance-point colour) and the
    shell (negative ids; floor / wall albedo from the capture's structural instances)."""

    meshes = []
    for i, (_, mesh) in sorted(placed.items()):
        color = _mean_color(capture, [i]) or (0.6, 0.6, 0.6)
        meshes.append(RenderMesh.uniform(int(i), mesh.vertices, mesh.faces, color, Texture.PLAIN))
    floors = [int(s.id) for s in capture.instances if s.structural and s.label == "floor"]
    walls = [int(s.id) for s in capture.instances if s.structural and s.label == "wall"]
    floor_color = _mean_color(capture, floors) or (0.6, 0.6, 0.6)
    wall_color = _mean_color(capture, walls) or (0.8, 0.8, 0.8)
    for k, (name, mesh) in enumerate(sorted(shell.items())):
        color = floor_color if name == "shell_floor" else wall_color
        meshes.append(RenderMesh.uniform(-(k + 1), mesh.vertices, mesh.faces, color, Texture.PLAIN))
    return meshes


def scaled(camera: Camera, scale: float) -> Camera:

    return scaled_camera(camera, scale)


class _Lpips:
    """LPIPS from a local weights file (no download: the backbone is built without pretrained weights and
    the whole state dict comes from the file)."""

    def __init__(self, path: str, net: str):
        try:
            import lpips
            import torch
        except ImportError as err:
            raise RuntimeError(
                f"LPIPS needs the `lpips` package ({err}); install it or leave lpips_weights unset"
            ) from err
        self.torch = torch
        self.model = lpips.LPIPS(net=net, pretrained=False, pnet_rand=True, verbose=False)
        state = torch.load(path, map_location="cpu", weights_only=True)
        self.model.load_state_dict(state, strict=True)
        self.model.eval()

    def __call__(self, a: NDArray, b: NDArray) -> float:
        def tensor(x):
            return self.torch.from_numpy(x.astype(np.float32) / 127.5 - 1.0).permute(2, 0, 1)[None]

        with self.torch.no_grad():
            return float(self.model(tensor(a), tensor(b)).item())


def rendering_metrics(
    placed: Mapping[int, tuple[str, trimesh.Trimesh]],
    shell: Mapping[str, trimesh.Trimesh],
    capture: Any,
    key_frames: Sequence[int] | None,
    config: RenderingConfig | None = None,
) -> dict[str, Any]:
    """Rendering metrics of the placed scene against the capture's frames that are not in ``key_frames``
    (None: no key frames known, every frame is used and ``frames_note`` says so). Plain JSON types."""

    config = config or RenderingConfig()
    out: dict[str, Any] = {"protocol": config.model_dump(mode="json"), "not_computed": {}}
    if not placed:
        out["not_computed"]["all"] = "the run placed no object"
        return out
    keys = set(int(k) for k in key_frames) if key_frames is not None else set()
    frames = [t for t in range(capture.num_frames) if t not in keys][:: max(1, config.frame_stride)]
    if key_frames is None:
        out["frames_note"] = "no keyframes.json: every capture frame is evaluated (key frames included)"
    if not frames:
        out["not_computed"]["all"] = "every capture frame is a key frame"
        return out
    renderer = Renderer(scene_render_meshes(placed, shell, capture), Shading(lights=(), ambient=1.0, gamma=1.0))
    objects = sorted(int(i.id) for i in capture.object_instances)
    ids = sorted(set(objects) | {int(i) for i in placed})
    lut_size = max(ids) + 1 if ids else 1
    lut = np.zeros(max(lut_size, 1), np.int64)
    lut[ids] = np.arange(1, len(ids) + 1)
    inter = np.zeros(len(ids) + 1)
    area_r = np.zeros(len(ids) + 1)
    area_c = np.zeros(len(ids) + 1)
    object_lut = np.zeros(lut_size, bool)
    object_lut[objects] = True
    depth_sums = {"abs_rel": 0.0, "sq": 0.0, "delta": 0.0, "n": 0, "valid_captured": 0}
    per_frame = []
    lpips = None
    if config.lpips_weights is None:
        out["not_computed"]["lpips"] = (
            "no local LPIPS weights given (rendering.lpips_weights); weights are never downloaded"
        )
    else:
        try:
            lpips = _Lpips(config.lpips_weights, config.lpips_net)
        except Exception as err:  # a bad weights file must not cost the other metrics
            out["not_computed"]["lpips"] = f"LPIPS could not load {config.lpips_weights}: {err}"
    if capture.depth is None:
        out["not_computed"]["depth"] = "the capture has no depth (frames/depth)"
    for t in frames:
        cam = scaled(capture.camera(t), config.scale)
        size = (cam.width, cam.height)
        frame = renderer.render(cam)
        rgb_c = _resize(np.asarray(capture.rgb[t]), size, nearest=False)
        mask_c = _resize(np.asarray(capture.instance_masks[t], np.int32), size, nearest=True)
        rend_ids = np.where(frame.ids > 0, frame.ids, 0)
        # instance IoU: ids outside the table map to 0 ("none")
        r_idx = lut[np.clip(rend_ids, 0, lut_size - 1)] * (rend_ids < lut_size)
        c_idx = lut[np.clip(mask_c, 0, lut_size - 1)] * ((mask_c >= 0) & (mask_c < lut_size))
        n = len(ids) + 1
        inter += np.bincount(r_idx[r_idx == c_idx], minlength=n)
        area_r += np.bincount(r_idx.ravel(), minlength=n)
        area_c += np.bincount(c_idx.ravel(), minlength=n)
        row: dict[str, Any] = {"frame": int(t)}
        if capture.depth is not None:
            d_c = _resize(np.asarray(capture.depth[t], np.float32), size, nearest=True)
            valid = (d_c > 0) & (frame.depth > 0)
            depth_sums["valid_captured"] += int((d_c > 0).sum())
            if valid.any():
                r, c = frame.depth[valid].astype(np.float64), d_c[valid].astype(np.float64)
                depth_sums["abs_rel"] += float(np.sum(np.abs(r - c) / c))
                depth_sums["sq"] += float(np.sum((r - c) ** 2))
                depth_sums["delta"] += float(np.sum(np.maximum(r / c, c / r) < config.delta))
                depth_sums["n"] += int(valid.sum())
        fg = object_lut[np.clip(mask_c, 0, lut_size - 1)] & (mask_c > 0) & (mask_c < lut_size)
        row["psnr"] = psnr(frame.rgb, rgb_c, None, config.psnr_cap)
        row["psnr_masked"] = psnr(frame.rgb, rgb_c, fg, config.psnr_cap)
        row["ssim"], row["ssim_masked"] = ssim(frame.rgb, rgb_c, fg, config.ssim_sigma)
        if lpips is not None:
            row["lpips"] = lpips(frame.rgb, rgb_c)
        per_frame.append(row)

    def mean(key: str) -> float | None:
        vals = [r[key] for r in per_frame if r.get(key) is not None]
        return float(np.mean(vals)) if vals else None

    union = area_r + area_c - inter
    per_object = []
    for k, i in enumerate(ids, start=1):
        if area_c[k] == 0 and i not in placed:
            continue
        per_object.append(
            {
                "instance": i,
                "label": placed[i][0] if i in placed else capture.instance(i).label,
                "placed": i in placed,
                "iou": float(inter[k] / union[k]) if union[k] > 0 else None,
                "pixels_rendered": int(area_r[k]),
                "pixels_captured": int(area_c[k]),
            }
        )
    placed_iou = [r["iou"] for r in per_object if r["placed"] and r["iou"] is not None]
    all_iou = [r["iou"] if r["placed"] else 0.0 for r in per_object if r["pixels_captured"] > 0]
    n_depth = depth_sums["n"]
    out.update(
        {
            "frames": [int(t) for t in frames],
            "key_frames_excluded": sorted(keys),
            "image_size": [
                scaled(capture.camera(frames[0]), config.scale).width,
                scaled(capture.camera(frames[0]), config.scale).height,
            ],
            "psnr": mean("psnr"),
            "psnr_masked": mean("psnr_masked"),
            "ssim": mean("ssim"),
            "ssim_masked": mean("ssim_masked"),
            "lpips": mean("lpips") if lpips is not None else None,
            "mask_iou_mean_placed": float(np.mean(placed_iou)) if placed_iou else None,
            "mask_iou_mean_all": float(np.mean(all_iou)) if all_iou else None,
            "per_object": per_object,
            "per_frame": per_frame,
        }
    )
    if capture.depth is not None:
        out["depth"] = {
            "abs_rel": depth_sums["abs_rel"] / n_depth if n_depth else None,
            "rmse": float(np.sqrt(depth_sums["sq"] / n_depth)) if n_depth else None,
            "delta_1.25": depth_sums["delta"] / n_depth if n_depth else None,
            "pixels": n_depth,
            "coverage": n_depth / depth_sums["valid_captured"] if depth_sums["valid_captured"] else None,
        }
    return out


__all__ = ["RenderingConfig", "psnr", "rendering_metrics", "scene_render_meshes", "ssim"]
