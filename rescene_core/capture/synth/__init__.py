"""Synthetic captures with ground truth: furnished rooms, a camera walk, a panoptic model's errors.

    scene = make_scene("standard", seed=0)           # SynthScene: .arrays (CaptureArrays), .gt (GroundTruth)
    write_synth("room.zarr", "standard", seed=0)      # the capture with its gt/ group

docs/synthetic-captures.md describes the presets, the error dials, the ground truth and the pictures.
"""

from rescene_core.capture.synth.presets import PRESETS, SynthPreset, get_preset
from rescene_core.capture.synth.scene import SynthScene, make_scene, write_scene, write_synth

__all__ = [
    "PRESETS",
    "SynthPreset",
    "SynthScene",
    "get_preset",
    "make_scene",
    "write_scene",
    "write_synth",
]
