"""The layout of a run directory, in one place.

``RunPaths(run_dir)`` names every file and folder the pipeline reads or writes under ``RUN/``; code asks
it for a path instead of joining literals. The templates below are the layout itself (docs/run-directory.md
lists the same paths, checked by tests/test_paths.py); ``{instance}`` is an instance id, ``{frame}`` a
key-frame index, ``{node}`` a scene node name, ``{name}`` a run-log segment name, ``{view}`` a VQA view id.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

# run-level files
MANIFEST = "manifest.json"
INSTANCE_TABLE = "instances.parquet"
CONFIG = "config.yaml"
SHELL = "shell.json"
KEYFRAMES = "keyframes.json"
LAYOUT = "layout.json"
FAULTS = "faults.json"
FAULT_COUNTS = ".faults/"
RESULTS = ".prefect/results/"
LOCK = ".lock"

# per instance
INSTANCES = "instances/"
VIEW = "instances/{instance}/view.json"
ASSET_META = "instances/{instance}/asset.json"
ASSET_GLB = "instances/{instance}/asset.glb"
POSE = "instances/{instance}/pose.json"

# scene graph
SCENEGRAPH = "scenegraph/"
FRAME_JSON = "scenegraph/frames/{frame}.json"
FRAME_PNG = "scenegraph/frames/{frame}.png"
GRAPH = "scenegraph/graph.json"
GRAPH_PNG = "scenegraph/graph.png"

# exports
SCENE = "scene/"
SCENE_GLB = "scene/scene.glb"
SCENE_USDA = "scene/scene.usda"
SCENE_USDC = "scene/scene.usdc"
SCENE_MJCF_DIR = "scene/mjcf/"
SCENE_MJCF = "scene/mjcf/scene.xml"
SCENE_JSON = "scene/scene.json"
EXPORT_REPORT = "scene/export_report.json"
SCENE_OBJECTS = "scene/objects/"
SCENE_OBJECT = "scene/objects/{node}.glb"
SCENE_POINTS = "scene/points.zarr"

# checks, evaluation, VQA
SIMCHECK = "sim/simcheck.json"
SIMCHECK_NEWTON = "sim/simcheck-newton.json"
SIM_PICTURE = "sim/before_after.png"
EVAL = "eval/"
METRICS = "eval/metrics.json"
REPORT_MD = "eval/report.md"
REPORT_HTML = "eval/report.html"
FIGURES = "eval/figures/"
VQA = "vqa/"
VQA_QUESTIONS = "vqa/questions.jsonl"
VQA_SUMMARY = "vqa/summary.json"
VQA_VIEWS = "vqa/views/"
VQA_VIEW = "vqa/views/{view}.png"

# run log
RUN_LOG = "logs/run.mcap"
SEGMENTS = "logs/segments/"
SEGMENT = "logs/segments/{name}.mcap"
AFTER_REGISTRATION = "logs/after_registration.json"

TEMPLATES: dict[str, str] = {k: v for k, v in dict(globals()).items() if k.isupper() and isinstance(v, str)}
"""Every path of the layout by its constant's name (a trailing ``/`` marks a folder)."""


def in_folder(folder: str | Path, template: str, folder_template: str, **values: object) -> Path:
    """The path of ``template`` when the folder ``folder_template`` of the layout is ``folder``: for a stage
    that writes its files into a folder the caller chooses (the run's, or another one with the same layout),
    e.g. ``in_folder(out, FRAME_JSON, SCENEGRAPH, frame=3)`` is ``out/frames/3.json``."""
    return Path(folder) / Path(template.format(**values)).relative_to(folder_template)


@dataclass(frozen=True)
class RunPaths:
    """The paths of one run directory. Methods take the item a path depends on; ``rel`` gives the
    run-relative form that task references carry."""

    root: Path

    def __init__(self, root: str | Path) -> None:
        object.__setattr__(self, "root", Path(root))

    def _at(self, template: str, **values: object) -> Path:
        return self.root / template.format(**values).rstrip("/")

    def rel(self, path: str | Path) -> str:
        """``path`` relative to the run directory, with forward slashes."""
        return Path(path).relative_to(self.root).as_posix()

    # run-level files
    @property
    def manifest(self) -> Path:
        return self._at(MANIFEST)

    @property
    def instance_table(self) -> Path:
        return self._at(INSTANCE_TABLE)

    @property
    def config(self) -> Path:
        return self._at(CONFIG)

    @property
    def shell(self) -> Path:
        return self._at(SHELL)

    @property
    def keyframes(self) -> Path:
        return self._at(KEYFRAMES)

    @property
    def layout(self) -> Path:
        return self._at(LAYOUT)

    @property
    def faults(self) -> Path:
        return self._at(FAULTS)

    @property
    def fault_counts(self) -> Path:
        return self._at(FAULT_COUNTS)

    def fault_count(self, segment: str) -> Path:
        """How often the injected fault of one task (named like its log segment) has fired."""
        return self.fault_counts / f"{segment}.count"

    @property
    def results(self) -> Path:
        return self._at(RESULTS)

    @property
    def lock(self) -> Path:
        """The run lock: present while a run holds the directory (rescene_core/runlock.py)."""
        return self._at(LOCK)

    # per instance
    @property
    def instances(self) -> Path:
        return self._at(INSTANCES)

    def instance_dir(self, instance: int) -> Path:
        return self.view(instance).parent

    def view(self, instance: int) -> Path:
        return self._at(VIEW, instance=int(instance))

    def asset_meta(self, instance: int) -> Path:
        return self._at(ASSET_META, instance=int(instance))

    def asset_glb(self, instance: int) -> Path:
        return self._at(ASSET_GLB, instance=int(instance))

    def pose(self, instance: int) -> Path:
        return self._at(POSE, instance=int(instance))

    # scene graph
    @property
    def scenegraph(self) -> Path:
        return self._at(SCENEGRAPH)

    def frame_json(self, frame: int) -> Path:
        return self._at(FRAME_JSON, frame=int(frame))

    def frame_png(self, frame: int) -> Path:
        return self._at(FRAME_PNG, frame=int(frame))

    @property
    def graph(self) -> Path:
        return self._at(GRAPH)

    @property
    def graph_png(self) -> Path:
        return self._at(GRAPH_PNG)

    # exports
    @property
    def scene(self) -> Path:
        return self._at(SCENE)

    @property
    def scene_glb(self) -> Path:
        return self._at(SCENE_GLB)

    @property
    def scene_usda(self) -> Path:
        return self._at(SCENE_USDA)

    @property
    def scene_usdc(self) -> Path:
        return self._at(SCENE_USDC)

    @property
    def scene_mjcf_dir(self) -> Path:
        return self._at(SCENE_MJCF_DIR)

    @property
    def scene_mjcf(self) -> Path:
        return self._at(SCENE_MJCF)

    @property
    def scene_json(self) -> Path:
        return self._at(SCENE_JSON)

    @property
    def export_report(self) -> Path:
        return self._at(EXPORT_REPORT)

    @property
    def scene_objects(self) -> Path:
        return self._at(SCENE_OBJECTS)

    def scene_object(self, node: str) -> Path:
        return self._at(SCENE_OBJECT, node=node)

    @property
    def scene_points(self) -> Path:
        return self._at(SCENE_POINTS)

    # checks, evaluation, VQA
    @property
    def simcheck(self) -> Path:
        return self._at(SIMCHECK)

    @property
    def simcheck_newton(self) -> Path:
        return self._at(SIMCHECK_NEWTON)

    @property
    def sim_picture(self) -> Path:
        return self._at(SIM_PICTURE)

    @property
    def eval(self) -> Path:
        return self._at(EVAL)

    @property
    def metrics(self) -> Path:
        return self._at(METRICS)

    @property
    def report_md(self) -> Path:
        return self._at(REPORT_MD)

    @property
    def report_html(self) -> Path:
        return self._at(REPORT_HTML)

    @property
    def figures(self) -> Path:
        return self._at(FIGURES)

    @property
    def vqa(self) -> Path:
        return self._at(VQA)

    @property
    def vqa_questions(self) -> Path:
        return self._at(VQA_QUESTIONS)

    @property
    def vqa_summary(self) -> Path:
        return self._at(VQA_SUMMARY)

    @property
    def vqa_views(self) -> Path:
        return self._at(VQA_VIEWS)

    def vqa_view(self, view: str) -> Path:
        return self._at(VQA_VIEW, view=view)

    # run log
    @property
    def run_log(self) -> Path:
        return self._at(RUN_LOG)

    @property
    def segments(self) -> Path:
        return self._at(SEGMENTS)

    def segment(self, name: str) -> Path:
        return self._at(SEGMENT, name=name)

    @property
    def after_registration(self) -> Path:
        return self._at(AFTER_REGISTRATION)
