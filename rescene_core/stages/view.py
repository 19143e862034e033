"""Stage ``view``: HierView for every instance in one call -> instances/<id>/view.json.

One call rather than one per instance: HierView shares its per-frame statistics (a pass over every mask
of every frame) between instances, so per-instance calls would repeat that pass N times; all instances
have the same inputs (the capture and the config), so nothing is lost for caching.
"""

from __future__ import annotations

from rescene_core.capture import open_capture
from rescene_core.config import HierViewConfig
from rescene_core.io import write_json_atomic
from rescene_core.paths import RunPaths
from rescene_core.records import InstanceId, Missing, Ref, Stage
from rescene_core.stages import calls
from rescene_core.stages.execution import executing, make_ref, passthrough


def run(run_dir: str, capture: Ref, instances: list[int], config: HierViewConfig) -> list[Ref]:
    """The chosen view of every instance; one reference per instance, in ``instances`` order."""
    run = RunPaths(run_dir)
    with executing(run_dir, Stage.VIEW) as seg:
        cap = open_capture(capture.path, validate=False)
        results = calls.select_views(cap, config, list(instances))
        refs = []
        for instance in instances:
            path = run.view(instance)
            result = results.get(instance)
            if result is None:
                result = Missing(InstanceId(instance), Stage.VIEW, "view selection returned nothing for this instance")
            if isinstance(result, Missing):
                seg.log("/hierview/view_scores", {"instance": instance, "frame": None, "reason": result.reason})
                refs.append(passthrough(run_dir, path, "view", instance, result))
                continue
            write_json_atomic(path, {"instance": instance, "status": "ok", "view": result.to_json()})
            seg.log(
                "/hierview/view_scores",
                {
                    "instance": instance,
                    "frame": result.frame,
                    "method": result.method,
                    "reason": result.reason,
                    "semantic_backend": result.semantic_backend,
                    "candidates": list(result.candidates),
                },
            )
            numbers = {"frame": result.frame, "candidates": len(result.candidates)}
            refs.append(make_ref(run_dir, path, "view", instance, numbers=numbers))
        return refs
