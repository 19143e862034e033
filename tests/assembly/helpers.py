"""Helpers for the assembly tests: perturb one object of the hand-built bedroom."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rescene_core.assembly.scenes import bedroom
from rescene_core.records import InstanceId


def moved(objects, instance: int, correction):
    """Copy of ``objects`` with object ``instance`` at ``correction @ world_from_asset``."""
    out = dict(objects)
    obj = out[InstanceId(instance)]
    out[InstanceId(instance)] = replace(obj, world_from_asset=np.asarray(correction) @ obj.world_from_asset)
    return out


def scene():
    return bedroom()
