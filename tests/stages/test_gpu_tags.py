"""A stage that may want a GPU worker is tagged for one only when the run's backend for it is a model."""

from __future__ import annotations

from rescene_core.config import RunConfig
from rescene_core.records import Stage
from rescene_core.stages.dag import DAG, SPECS


def test_weight_free_backends_want_no_gpu_models_do():
    cpu = RunConfig()
    assert cpu.assets.backend == "lift" and cpu.scenegraph.backend == "geometric"
    assert not any(spec.wants_gpu(cpu) for spec in DAG)
    models = RunConfig().with_overrides(["assets.backend=sam3d", "scenegraph.backend=openai"])
    assert {spec.stage for spec in DAG if spec.wants_gpu(models)} == {Stage.ASSET, Stage.RELATIONS}
    vlm_only = RunConfig().with_overrides(["scenegraph.backend=openai"])
    assert SPECS[Stage.RELATIONS].wants_gpu(vlm_only) and not SPECS[Stage.ASSET].wants_gpu(vlm_only)
