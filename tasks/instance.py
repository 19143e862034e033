"""Instance tasks: view selection (all instances at once), then asset generation -> registration mapped
over instances. Each runs one stage body of ``rescene_core.stages`` (which writes
``RUN/instances/<id>/{view,asset,pose}.json`` and ``asset.glb``) and returns its ``Ref``; an instance a
stage cannot handle comes back as an explicit Missing (status MISSING) that later stages pass through.
"""

from __future__ import annotations

from rescene_core.config import AssetConfig, HierViewConfig, RegistrationConfig
from rescene_core.records import Ref, Stage
from rescene_core.stages.dag import SPECS
from tasks.common import stage_task


@stage_task(Stage.VIEW)
def select_views(run_dir: str, capture: Ref, instances: list[int], config: HierViewConfig) -> list[Ref]:
    """HierView for every instance in one call -> instances/<id>/view.json; one reference per instance."""
    return SPECS[Stage.VIEW].run(run_dir, capture, instances, config)


@stage_task(Stage.ASSET, tags=("gpu",))
def generate_asset(run_dir: str, capture: Ref, view: Ref, config: AssetConfig) -> Ref:
    """Asset generation from the chosen view -> instances/<id>/asset.glb + asset.json."""
    return SPECS[Stage.ASSET].run(run_dir, capture, view, config)


@stage_task(Stage.REGISTRATION)
def register_instance(run_dir: str, capture: Ref, asset: Ref, config: RegistrationConfig) -> Ref:
    """Bounded Sim(3) registration of the asset to the instance points -> instances/<id>/pose.json."""
    return SPECS[Stage.REGISTRATION].run(run_dir, capture, asset, config)
