"""The Prefect task of every stage of ``rescene_core.stages.dag.DAG``: the stage body itself, wrapped by
``tasks.common.task_of`` (input-hash cache policy, JSON results, retries on transient errors, the ``gpu``
tag). A task loads its inputs from the run directory, calls its library, writes its output atomically and
returns a ``Ref``; the flow (flows/scene.py) wires them. The names below are how the flow reads.
"""

from __future__ import annotations

from typing import Any

# matplotlib.pyplot reads sys.modules["IPython"] when first imported and open3d imports IPython: two task
# threads importing them at once (the physics check's picture, the evaluation) fail on the half initialised
# module, so pyplot is imported here, once, before any task thread starts.
import matplotlib.pyplot  # noqa: F401
from prefect import Task

from rescene_core.records import Stage
from rescene_core.stages.dag import DAG
from tasks.common import task_of

TASKS: dict[Stage, Task[..., Any]] = {spec.stage: task_of(spec) for spec in DAG}
"""One task per declared stage."""

validate_capture = TASKS[Stage.VALIDATE]
estimate_shell = TASKS[Stage.SHELL]
select_views = TASKS[Stage.VIEW]
generate_asset = TASKS[Stage.ASSET]
register_instance = TASKS[Stage.REGISTRATION]
select_keyframes = TASKS[Stage.KEYFRAMES]
predict_relations = TASKS[Stage.RELATIONS]
fuse_graph = TASKS[Stage.FUSION]
snapshot_registration = TASKS[Stage.SNAPSHOT]
attach_layout = TASKS[Stage.ATTACHMENT]
export = TASKS[Stage.EXPORT]
simcheck = TASKS[Stage.SIMCHECK]
evaluate = TASKS[Stage.EVALUATION]
