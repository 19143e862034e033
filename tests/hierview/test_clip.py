"""The CLIP backend with a tiny randomly initialised open_clip model built here (no downloads, no network)."""

from __future__ import annotations

import json
import socket

import numpy as np
import open_clip
import pytest
import torch

from rescene_core.config import HierViewConfig
from rescene_core.hierview import ClipScorer, ClipUnavailableError, select_views
from rescene_core.hierview.semantic import CLIP_WEIGHTS_ENV, make_scorer
from rescene_core.records import ViewChoice

TINY = "rescene-tiny-clip"
TINY_CONFIG = {
    "embed_dim": 16,
    "vision_cfg": {"image_size": 32, "layers": 1, "width": 32, "patch_size": 16, "head_width": 16},
    "text_cfg": {"context_length": 77, "vocab_size": 49408, "width": 32, "heads": 2, "layers": 1},
}


@pytest.fixture(autouse=True)
def no_network(monkeypatch):
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")

    def refuse(*args, **kwargs):
        raise OSError("network access is not allowed in tests")

    monkeypatch.setattr(socket.socket, "connect", refuse)


@pytest.fixture(scope="module")
def tiny_weights(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clip")
    (folder / f"{TINY}.json").write_text(json.dumps(TINY_CONFIG))
    open_clip.add_model_config(folder)
    torch.manual_seed(0)
    model = open_clip.create_model(TINY, pretrained=None)
    path = folder / "tiny.pt"
    torch.save(model.state_dict(), path)
    return path


def test_clip_scores_are_probabilities(room_capture, tiny_weights):
    config = HierViewConfig(semantic_backend="clip", clip_model=TINY, clip_weights=str(tiny_weights), clip_batch_size=4)
    scorer = ClipScorer(config)
    frames = np.flatnonzero(np.asarray(room_capture.instance_masks[...] == 11).sum(axis=(1, 2)) >= 100)
    probs = scorer.score(room_capture, {11: frames, 12: frames[:2]})
    assert probs[11].shape == (len(frames),) and ((probs[11] > 0) & (probs[11] < 1)).all()
    labels = sorted({i.label for i in room_capture.instances} | {"object"})
    emb = scorer.text_embeddings(labels)
    assert emb.shape == (len(labels), 16) and np.allclose(np.linalg.norm(emb, axis=1), 1, atol=1e-5)
    assert len(scorer._text_cache) == len(labels)  # cached per prompt
    # batching does not change the result
    again = ClipScorer(config.model_copy(update={"clip_batch_size": 64})).score(room_capture, {11: frames})
    np.testing.assert_allclose(again[11], probs[11], atol=1e-5)


def test_select_views_with_clip_records_the_backend(room_capture, tiny_weights, monkeypatch):
    monkeypatch.setenv(CLIP_WEIGHTS_ENV, str(tiny_weights))
    views = select_views(room_capture, HierViewConfig(semantic_backend="clip", clip_model=TINY))
    assert all(isinstance(v, ViewChoice) and v.semantic_backend == "clip" for v in views.values())
    assert all("semantic (clip)" in v.reason for v in views.values())


def test_unseen_label_gives_a_recorded_choice(room, tmp_path, tiny_weights):
    import dataclasses

    from rescene_core.capture import open_capture, write_capture
    from rescene_core.records import Instance

    insts = tuple(
        Instance(i.id, "zxqv quasi-gizmo 9000" if i.id == 11 else ("" if i.id == 12 else i.label), i.structural)
        for i in room.arrays.instances
    )
    cap = open_capture(
        write_capture(tmp_path / "c.zarr", dataclasses.replace(room.arrays, instances=insts)), validate=False
    )
    config = HierViewConfig(semantic_backend="clip", clip_model=TINY, clip_weights=str(tiny_weights))
    views = select_views(cap, config, instance_ids=[11, 12])
    for v in views.values():
        assert isinstance(v, ViewChoice) and v.semantic_backend == "clip"
        assert all(r["semantic"] is not None for r in v.candidates if r["stage_reached"] != "candidate")


def test_missing_weights_fall_back_and_say_so(room_capture, monkeypatch, tmp_path):
    monkeypatch.delenv(CLIP_WEIGHTS_ENV, raising=False)
    with pytest.raises(ClipUnavailableError, match="no CLIP weights configured"):
        ClipScorer(HierViewConfig(semantic_backend="clip"))
    config = HierViewConfig(semantic_backend="clip", clip_weights=str(tmp_path / "absent.pt"))
    scorer, note = make_scorer(config)
    assert scorer.name == "appearance" and "not found" in note
    choice = select_views(room_capture, config, instance_ids=[11])[11]
    assert choice.semantic_backend == "appearance" and "clip unavailable" in choice.reason
    none = select_views(room_capture, config.model_copy(update={"semantic_fallback": "none"}), instance_ids=[11])[11]
    assert none.semantic_backend == "none" and "clip unavailable" in none.reason


def test_weights_that_do_not_fit_the_model_fall_back(room_capture, tmp_path, tiny_weights):
    bad = tmp_path / "bad.pt"
    torch.save({"not": torch.zeros(1)}, bad)
    config = HierViewConfig(semantic_backend="clip", clip_model=TINY, clip_weights=str(bad))
    scorer, note = make_scorer(config)
    assert scorer.name == "appearance" and "cannot build" in note
