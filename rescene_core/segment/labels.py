"""Zero-shot labels for label-free segments: open_clip over a vocabulary on each segment's best views.

The model is loaded from a local checkpoint with the same loader HierView's CLIP scorer uses (weights are
never downloaded); it runs on the GPU when torch sees one. A segment's label is the vocabulary entry with
the highest mean probability over its largest masks.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rescene_core.config import HierViewConfig
from rescene_core.hierview.semantic import ClipScorer, ClipUnavailableError
from rescene_core.segment.errors import SegmentError


def zero_shot_labels(
    rgb: NDArray[np.uint8],
    masks: NDArray[np.int32],
    ids: list[int],
    weights: str | Path,
    model_name: str,
    vocabulary: tuple[str, ...],
    views: int = 3,
) -> tuple[dict[int, str], dict[str, Any]]:
    """{id: label} for the segments ``ids`` and a report (device, model, per-segment probabilities)."""
    try:
        import torch
    except ImportError as err:
        raise SegmentError(
            f"CLIP labels of segments need torch and open_clip ({err}); pip install 'rescene[clip]'"
        ) from err

    if not vocabulary:
        raise SegmentError("the zero-shot vocabulary is empty; pass at least one label")
    try:
        scorer = ClipScorer(HierViewConfig(semantic_backend="clip", clip_model=model_name, clip_weights=str(weights)))
    except ClipUnavailableError as err:
        raise SegmentError(f"cannot label segments with CLIP: {err}") from err
    device = "cuda" if torch.cuda.is_available() else "cpu"
    model = scorer.model if device == "cpu" else copy.deepcopy(scorer.model).to(device)
    text = torch.from_numpy(scorer.text_embeddings(list(vocabulary))).to(device)
    scale = float(model.logit_scale.detach().exp()) if hasattr(model, "logit_scale") else 100.0
    area = np.stack([np.bincount(masks[t].ravel(), minlength=max(ids) + 1)[: max(ids) + 1] for t in range(len(masks))])
    out: dict[int, str] = {}
    detail: dict[str, Any] = {}
    for i in ids:
        best = [int(t) for t in np.argsort(-area[:, i], kind="stable")[:views] if area[t, i] > 0]
        if not best:
            out[i] = "object"
            continue
        crops = [scorer.preprocess(scorer._crop(np.asarray(rgb[t]), np.asarray(masks[t]) == i)) for t in best]
        with torch.no_grad():
            feats = model.encode_image(torch.stack(crops).to(device)).float()
            feats = feats / feats.norm(dim=-1, keepdim=True).clamp_min(1e-12)
            probs = torch.softmax(scale * feats @ text.T, dim=-1).mean(dim=0).cpu().numpy()
        k = int(np.argmax(probs))
        out[i] = vocabulary[k]
        detail[str(i)] = {"label": vocabulary[k], "probability": round(float(probs[k]), 4), "views": best}
    return out, {"labeller": f"open_clip {model_name}", "weights": str(weights), "device": device, "segments": detail}
