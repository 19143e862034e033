"""Workers that load models once (SAM 3D pipeline, relation predictor / VLM client, CLIP) and the shared
VLM concurrency limit (a Prefect global concurrency limit named by RESCENE_VLM_LIMIT)."""

from __future__ import annotations

import pytest

from rescene_core.config import AssetConfig, RunConfig


def test_sam3d_pipeline_loaded_once_per_process(tmp_path):
    from rescene_core.assets.sam3d import Sam3dBackend

    (tmp_path / "pipeline.yaml").write_text("{}\n")
    clone = tmp_path / "clone"
    (clone / "notebook").mkdir(parents=True)
    (clone / "notebook" / "inference.py").write_text(
        "class Inference:\n"
        "    built = []\n"
        "    def __init__(self, config_file, compile=False):\n"
        "        Inference.built.append(config_file)\n"
    )
    config = AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path), sam3d_code_dir=str(clone))
    first, second = Sam3dBackend(config), Sam3dBackend(config.model_copy(update={"seed": 7}))
    assert first.inference is second.inference  # one loaded pipeline for every instance and task
    assert first.seed != second.seed
    assert type(first.inference).built == [str((tmp_path / "pipeline.yaml").resolve())]


def test_relation_predictor_built_once_per_config():
    from rescene_core.scenegraph import make_predictor

    config = RunConfig().scenegraph
    assert make_predictor(config) is make_predictor(config.model_copy(deep=True))
    other = RunConfig().with_overrides(["scenegraph.backend=openai", "scenegraph.vlm.base_url=http://127.0.0.1:9/v1"])
    vlm = make_predictor(other.scenegraph)
    assert vlm is make_predictor(other.scenegraph) and vlm is not make_predictor(config)


def test_clip_device_follows_torch():
    torch = pytest.importorskip("torch")
    from rescene_core.hierview.semantic import clip_device

    assert clip_device() == ("cuda" if torch.cuda.is_available() else "cpu")


def test_vlm_slot_shared_limit(prefect_server, monkeypatch):
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.actions import GlobalConcurrencyLimitCreate

    from tasks.common import VLM_LIMIT_ENV, ConcurrencyLimitMissingError, vlm_slot

    monkeypatch.delenv(VLM_LIMIT_ENV, raising=False)
    with vlm_slot("http://gpu:8000/v1"):  # unset: no limit
        pass
    monkeypatch.setenv(VLM_LIMIT_ENV, "vlm-not-created")
    with pytest.raises(ConcurrencyLimitMissingError, match="prefect gcl create vlm-not-created"):
        with vlm_slot("http://gpu:8000/v1"):
            pass
    with get_client(sync_client=True) as client:
        client.create_global_concurrency_limit(GlobalConcurrencyLimitCreate(name="vlm-gpu-8000", limit=1))
        monkeypatch.setenv(VLM_LIMIT_ENV, "vlm-gpu-8000")
        with vlm_slot("http://gpu:8000/v1"):
            held = client.read_global_concurrency_limit_by_name("vlm-gpu-8000")
            assert held.active_slots == 1
        assert client.read_global_concurrency_limit_by_name("vlm-gpu-8000").active_slots == 0
