"""Which device each stage's models ran on goes into the run log (the end event of each execution and
`rescene log`). Checked here on the CPU with a tiny random CLIP and a stand-in for SAM 3D's Inference; not
yet run on a GPU (docs/orchestration.md)."""

from __future__ import annotations

import json
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from rescene_core.ops.devices import note_device, recording_devices
from rescene_core.records import Stage
from rescene_core.runlog import merge_segments, read_messages
from rescene_core.runlog.summary import format_summary, summarise
from rescene_core.stages.execution import executing


def _end_devices(run_dir, stage: str) -> dict[str, str]:
    events = read_messages(merge_segments(run_dir), ["/task/events"])
    (end,) = [m for _, _, m in events if m["event"] == "end" and m["stage"] == stage]
    return end["devices"]


def test_notes_belong_to_the_execution_that_made_them():
    note_device("clip", "cpu")  # outside any stage execution: nowhere to go, no error
    seen: dict[str, dict[str, str]] = {}
    barrier = threading.Barrier(2)

    def stage(name: str, device: str) -> None:
        with recording_devices() as devices:
            barrier.wait()  # both executions open at once, as two tasks of one worker's thread pool
            note_device(name, device)
            barrier.wait()
        seen[name] = devices

    threads = [threading.Thread(target=stage, args=a) for a in (("clip", "cuda:0"), ("sam3d", "cpu"))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert seen == {"clip": {"clip": "cuda:0"}, "sam3d": {"sam3d": "cpu"}}


def test_view_stage_logs_the_clip_device(tmp_path):
    torch = pytest.importorskip("torch")
    open_clip = pytest.importorskip("open_clip")
    from rescene_core.config import HierViewConfig
    from rescene_core.hierview import ClipScorer
    from tests.hierview.test_clip import TINY, TINY_CONFIG

    (tmp_path / f"{TINY}.json").write_text(json.dumps(TINY_CONFIG))
    open_clip.add_model_config(tmp_path)
    torch.manual_seed(0)
    torch.save(open_clip.create_model(TINY, pretrained=None).state_dict(), tmp_path / "tiny.pt")
    config = HierViewConfig(semantic_backend="clip", clip_model=TINY, clip_weights=str(tmp_path / "tiny.pt"))
    run = tmp_path / "run"
    with executing(run, Stage.VIEW):
        ClipScorer(config)
    with executing(run, Stage.SHELL):  # a stage without a torch model records none
        pass
    expected = "cuda:0" if torch.cuda.is_available() else "cpu"
    assert _end_devices(run, "view") == {"clip": expected}
    assert _end_devices(run, "shell") == {}
    text = format_summary(summarise(run))
    assert summarise(run)["devices"] == {"view": [f"clip {expected}"]}
    assert f"  view           clip {expected}" in text


def test_sam3d_backend_logs_where_its_pipeline_sits(tmp_path):
    pytest.importorskip("torch")
    from rescene_core.assets.sam3d import Sam3dBackend
    from rescene_core.config import AssetConfig

    (tmp_path / "pipeline.yaml").write_text("{}\n")
    clone = tmp_path / "clone"
    (clone / "notebook").mkdir(parents=True)
    (clone / "notebook" / "inference.py").write_text(
        "import torch\n"
        "class Inference:\n"
        "    def __init__(self, config_file, compile=False):\n"
        "        self.model = torch.nn.Linear(2, 2)\n"
        "    def __call__(self, rgb, mask, seed=0):\n"
        "        raise RuntimeError('a stand-in pipeline generates nothing')\n"
    )
    backend = Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path), sam3d_code_dir=str(clone)))
    assert backend.device == "cpu"
    view = SimpleNamespace(rgb=np.zeros((4, 4, 3), np.uint8), mask=np.ones((4, 4), bool))
    with recording_devices() as devices:
        with pytest.raises(RuntimeError, match="stand-in"):  # the device is noted before the pipeline runs
            backend.generate(view)  # type: ignore[arg-type]
    assert devices == {"sam3d": "cpu"}
