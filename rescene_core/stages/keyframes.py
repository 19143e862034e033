"""Stage ``keyframes``: key frames by greedy 3D coverage -> keyframes.json."""

from __future__ import annotations

from rescene_core.capture import open_capture
from rescene_core.config import KeyFrameConfig
from rescene_core.hierview import KeyFrames
from rescene_core.io import read_json, write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.execution import executing, make_ref


def run(run_dir: str, capture: Ref, config: KeyFrameConfig) -> Ref:
    """Key frames -> keyframes.json (read back with ``keyframes_of``)."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.KEYFRAMES) as seg:
        kf = calls.select_keyframes(open_capture(capture.path, validate=False), config)
        data = kf.to_json()
        write_json_atomic(run.keyframes, data)
        frames = [int(t) for t in kf.frames]
        seg.log(
            "/hierview/keyframes", {"frames": frames, "diagnostics": {k: v for k, v in data.items() if k != "frames"}}
        )
        return make_ref(run_dir, run.keyframes, "keyframes", numbers={"count": len(frames)})


def keyframes_of(run_dir: str, ref: Ref) -> list[int]:
    """The key frames of a key-frame reference, in selection order (its keyframes.json, typed)."""
    return list(KeyFrames.from_json(read_json(RunPaths(run_dir).root / ref.path)).frames)
