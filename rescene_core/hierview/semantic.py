"""Semantic scorers for HierView's second stage, behind one small protocol.

A scorer returns, for every requested (instance, candidate frame), a probability in [0, 1] that the masked
crop shows that instance's category; ``tau_s`` applies to it. Backends:

- ``clip``: open_clip (paper: ViT-B/32). The masked crop ``I_v * m_{i,v}`` and the prompts of the capture's
  label set are encoded; the probability is the softmax over the label set (CLIP's zero-shot classifier)
  at the instance's own label. Weights come only from a local file (``HierViewConfig.clip_weights`` or the
  ``RESCENE_CLIP_WEIGHTS`` environment variable); nothing is downloaded.
- ``appearance``: weight-free. Colour histograms (rg chromaticity x brightness) of every instance in every
  frame; an instance's reference is the element-wise median of its views' histograms (robust to a minority
  of drifted masks). Each colour bin gets the posterior P(instance i | bin) against the instance's
  colour-distinguishable competitors (the other instances' references as likelihoods), and a candidate's
  probability is the mean of that posterior over the crop's pixels: the fraction of the masked crop that
  looks like instance i. A mask that drifted onto another object scores about the fraction still on i.
- ``none``: no semantic filtering (every candidate scores 1).
"""

from __future__ import annotations

import functools
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from rescene_core.capture import Capture
from rescene_core.config import HierViewConfig
from rescene_core.hierview.projection import LabelTable
from rescene_core.ops.devices import note_device

log = logging.getLogger(__name__)

CLIP_WEIGHTS_ENV = "RESCENE_CLIP_WEIGHTS"
"""Environment variable naming a local CLIP weights file, read when ``clip_weights`` is unset."""

Requests = dict[int, NDArray[np.int64]]
"""instance id -> candidate frame indices [k] to score."""


class SemanticScorer(Protocol):
    """Scores masked crops against instance categories; ``name`` is recorded in every ViewChoice.

    A scorer may set ``calibrated = False`` when its score ranks one instance's views but is not a class
    probability (``select`` then keeps the views at or above the instance's median score as well, since
    ``tau_s`` means nothing to such a score); scorers without the attribute count as calibrated."""

    name: str

    def score(self, capture: Capture, requests: Requests) -> dict[int, NDArray[np.float64]]:
        """Probability [k] per instance, aligned with ``requests[instance]``."""
        ...


class NoneScorer:
    """No semantic stage: every candidate gets probability 1."""

    name = "none"

    def score(self, capture: Capture, requests: Requests) -> dict[int, NDArray[np.float64]]:
        return {i: np.ones(len(f)) for i, f in requests.items()}


class AppearanceScorer:
    """Weight-free colour-consistency scorer (see the module docstring)."""

    name = "appearance"
    calibrated = False
    """Its score is the share of a crop that looks like the instance's other views: it ranks one instance's
    views, but is no class probability (a large piece of furniture scores 0.05-0.12 in every view)."""

    def __init__(self, config: HierViewConfig):
        self.config = config

    def _bins(self, rgb: NDArray[np.uint8]) -> NDArray[np.int64]:
        """Histogram bin [H, W] of each pixel: rg chromaticity (b x b) times brightness (c levels)."""
        b, c = self.config.appearance_bins, self.config.appearance_brightness_bins
        x = rgb.astype(np.float32)
        s = x.sum(axis=2)
        safe = np.maximum(s, 1.0)
        r = np.minimum((x[..., 0] / safe * b).astype(np.int64), b - 1)
        g = np.minimum((x[..., 1] / safe * b).astype(np.int64), b - 1)
        v = np.minimum((s / 766.0 * c).astype(np.int64), c - 1)
        return (r * b + g) * c + v

    def histograms(self, capture: Capture, table: LabelTable) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
        """Normalised colour histograms [T, N, B] of every tracked instance in every frame, and areas [T, N]."""
        nb = self.config.appearance_bins**2 * self.config.appearance_brightness_bins
        n = table.n
        hists = np.zeros((capture.num_frames, n, nb), np.float32)
        areas = np.zeros((capture.num_frames, n), np.int64)
        for t in range(capture.num_frames):
            labels = table.compact(capture.instance_masks[t])
            bins = self._bins(np.asarray(capture.rgb[t]))
            counts = np.bincount((labels * nb + bins).ravel(), minlength=(n + 1) * nb).reshape(n + 1, nb)[1:]
            area = counts.sum(axis=1)
            areas[t] = area
            hists[t] = counts / np.maximum(area, 1)[:, None]
        return hists, areas

    def score(self, capture: Capture, requests: Requests) -> dict[int, NDArray[np.float64]]:
        if not requests:
            return {}
        table = LabelTable.build([inst.id for inst in capture.instances] + list(requests))
        hists, areas = self.histograms(capture, table)
        n = table.n
        refs = np.zeros((n, hists.shape[2]), np.float32)
        for k in range(n):
            good = areas[:, k] >= self.config.min_mask_area
            if not good.any():
                good = areas[:, k] > 0
            if good.any():
                ref = np.median(hists[good, k], axis=0)
                refs[k] = ref / max(float(ref.sum()), 1e-12)
        root_refs = np.sqrt(refs)
        ref_sim = root_refs @ root_refs.T  # Bhattacharyya coefficients between references [n, n]
        has_ref = refs.sum(axis=1) > 0
        like = refs + self.config.appearance_floor  # per-bin colour likelihood of each instance [n, B]
        out: dict[int, NDArray[np.float64]] = {}
        for inst_id, frames in requests.items():
            k = table.index_of(int(inst_id))
            if k < 0 or not has_ref[k] or len(frames) == 0:
                out[inst_id] = np.ones(len(frames))
                continue
            competitors = has_ref & (ref_sim[k] < self.config.appearance_same_similarity)
            competitors[k] = False
            own = like[k] / (like[k] + like[competitors].sum(axis=0))  # P(pixel is instance k | its bin) [B]
            out[inst_id] = (hists[frames, k] @ own).astype(np.float64)
        return out


class ClipUnavailableError(RuntimeError):
    """The CLIP backend cannot run: no local weights, or the model cannot be built from them."""


def resolve_clip_weights(config: HierViewConfig) -> Path:
    """The local CLIP weights file, from the config or ``RESCENE_CLIP_WEIGHTS``; raises when not found."""
    raw = config.clip_weights or os.environ.get(CLIP_WEIGHTS_ENV)
    if not raw:
        raise ClipUnavailableError(
            f"no CLIP weights configured: set hierview.clip_weights or {CLIP_WEIGHTS_ENV} to a local "
            f"open_clip {config.clip_model} checkpoint (weights are never downloaded)"
        )
    path = Path(raw).expanduser()
    if not path.is_file():
        raise ClipUnavailableError(f"CLIP weights not found at {path}")
    return path


def clip_device() -> str:
    """ "cuda" when torch sees a GPU, else "cpu"."""
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


@functools.lru_cache(maxsize=2)
def _load_clip(model_name: str, weights: str, mtime: float):
    """(model, preprocess, tokenizer) in eval mode on ``clip_device()``; loaded once per process, weights
    file and its mtime, so every task and flow run of a worker reuses it."""
    try:
        import open_clip
    except ImportError as err:
        raise ClipUnavailableError(
            f"the clip semantic backend needs open_clip and torch ({err}); pip install 'rescene[clip]'"
        ) from err
    try:
        model, _, preprocess = open_clip.create_model_and_transforms(
            model_name, pretrained=weights, device=clip_device()
        )
        tokenizer = open_clip.get_tokenizer(model_name)
    except Exception as err:  # any load failure becomes a recorded fallback, not a crash
        raise ClipUnavailableError(f"cannot build open_clip {model_name} from {weights}: {err}") from err
    model.eval()
    return model, preprocess, tokenizer


@dataclass
class ClipScorer:
    """open_clip zero-shot probability of the instance's label over the capture's label set."""

    config: HierViewConfig
    name: str = "clip"

    def __post_init__(self) -> None:
        self.weights = resolve_clip_weights(self.config)
        self.model, self.preprocess, self.tokenizer = _load_clip(
            self.config.clip_model, str(self.weights), self.weights.stat().st_mtime
        )
        self.device = next(self.model.parameters()).device
        note_device(self.name, self.device)
        self._text_cache: dict[str, NDArray[np.float32]] = {}

    def _prompt(self, label: str) -> str:
        text = label.strip().replace("_", " ") or "object"
        return self.config.clip_prompt.format(text)

    def text_embeddings(self, labels: list[str]) -> NDArray[np.float32]:
        """Unit text embeddings [L, D] of the labels' prompts (cached per prompt)."""
        import torch

        prompts = [self._prompt(lab) for lab in labels]
        todo = [p for p in dict.fromkeys(prompts) if p not in self._text_cache]
        if todo:
            with torch.no_grad():
                feats = self.model.encode_text(self.tokenizer(todo).to(self.device)).float()
                feats = feats / feats.norm(dim=-1, keepdim=True).clamp_min(1e-12)
            for p, f in zip(todo, feats.cpu().numpy()):
                self._text_cache[p] = f
        return np.stack([self._text_cache[p] for p in prompts])

    def _crop(self, rgb: NDArray[np.uint8], mask: NDArray[np.bool_]):

        rows = np.flatnonzero(mask.any(axis=1))
        cols = np.flatnonzero(mask.any(axis=0))
        h, w = mask.shape
        pad_r = int((rows[-1] - rows[0] + 1) * self.config.clip_crop_margin)
        pad_c = int((cols[-1] - cols[0] + 1) * self.config.clip_crop_margin)
        r0, r1 = max(0, rows[0] - pad_r), min(h, rows[-1] + 1 + pad_r)
        c0, c1 = max(0, cols[0] - pad_c), min(w, cols[-1] + 1 + pad_c)
        masked = np.where(mask[r0:r1, c0:c1, None], rgb[r0:r1, c0:c1], 0).astype(np.uint8)
        return Image.fromarray(masked)

    def score(self, capture: Capture, requests: Requests) -> dict[int, NDArray[np.float64]]:
        import torch

        labels = sorted({inst.label for inst in capture.instances} | {"object"})
        label_of = {int(inst.id): inst.label for inst in capture.instances}
        text = torch.from_numpy(self.text_embeddings(labels)).to(self.device)
        label_index = {lab: j for j, lab in enumerate(labels)}
        by_frame: dict[int, list[tuple[int, int]]] = {}
        for inst_id, frames in requests.items():
            for j, t in enumerate(frames):
                by_frame.setdefault(int(t), []).append((inst_id, j))
        out = {i: np.zeros(len(f)) for i, f in requests.items()}
        batch: list[tuple[int, int, object]] = []
        scale = float(self.model.logit_scale.detach().exp()) if hasattr(self.model, "logit_scale") else 100.0

        def flush() -> None:
            if not batch:
                return
            with torch.no_grad():
                images = torch.stack([self.preprocess(img) for _, _, img in batch]).to(self.device)
                feats = self.model.encode_image(images).float()
                feats = feats / feats.norm(dim=-1, keepdim=True).clamp_min(1e-12)
                probs = torch.softmax(scale * feats @ text.T, dim=-1).cpu().numpy()
            for (inst_id, j, _), p in zip(batch, probs):
                label = label_of.get(inst_id, "object")
                out[inst_id][j] = float(p[label_index.get(label, label_index["object"])])
            batch.clear()

        for t in sorted(by_frame):
            mask = np.asarray(capture.instance_masks[t])
            rgb = np.asarray(capture.rgb[t])
            for inst_id, j in by_frame[t]:
                m = mask == inst_id
                if not m.any():
                    continue
                batch.append((inst_id, j, self._crop(rgb, m)))
                if len(batch) >= self.config.clip_batch_size:
                    flush()
        flush()
        return out


def make_scorer(config: HierViewConfig) -> tuple[SemanticScorer, str]:
    """The configured scorer, and a note saying why another ran instead ('' when the configured one runs)."""
    if config.semantic_backend == "clip":
        try:
            return ClipScorer(config), ""
        except ClipUnavailableError as err:
            note = f"clip unavailable ({err}); ran the '{config.semantic_fallback}' fallback"
            log.warning("HierView semantic stage: %s", note)
            fallback = AppearanceScorer(config) if config.semantic_fallback == "appearance" else NoneScorer()
            return fallback, note
    if config.semantic_backend == "appearance":
        return AppearanceScorer(config), ""
    return NoneScorer(), ""
