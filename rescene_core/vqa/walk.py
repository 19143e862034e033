"""The embodied agent's egocentric walk (paper Sec. 'Viewpoint sampling and rendering').

The agent starts at a random navigable position: a point of the free floor space (the floor polygon
shrunk by ``wall_clearance``, minus every object footprint grown by ``object_clearance``), at the fixed
eye height ``walk_eye_height`` above the floor, with a random yaw and a level gaze. It then executes
``walk_steps`` discrete actions drawn with the seed:

- ``forward``: move ``walk_step_m`` along the heading; the straight segment must stay in the free space
  (shapely), else the move is blocked and the agent turns by ``walk_turn_deg`` instead (``blocked``);
- ``turn_left`` / ``turn_right``: change the yaw by ``walk_turn_deg``;
- ``look_up`` / ``look_down``: change the pitch by ``walk_look_deg``, within +-``walk_look_max_deg``.

After each action the agent captures a view: the project's ray-casting renderer gives the RGB image and
the id buffer, and every object covering at least ``min_visible_pixels`` is visible (the first hit of each
ray, so occluded parts do not count). A capture that sees no object is not kept; a walk that sees nothing starts again (``WALK_RESTARTS``).
Deterministic for a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rescene_core.geometry.camera import look_at
from rescene_core.records import Camera
from rescene_core.render import RenderedFrame, Renderer
from rescene_core.vqa.config import VqaConfig
from rescene_core.vqa.render import Viewpoint, free_space, intrinsics, visible_objects
from rescene_core.vqa.scene import VqaInputError, VqaScene

ACTIONS = ("forward", "turn_left", "turn_right", "look_up", "look_down")
"""The agent's discrete actions (a blocked forward move becomes a turn and is recorded as ``blocked``)."""
WALK_RESTARTS = 3
"""A walk none of whose captures sees an object (e.g. it started facing a wall) starts again from a new
random pose, at most this many times."""


@dataclass(frozen=True)
class AgentPose:
    """Eye position [3] (world, metres), yaw (degrees, counter-clockwise from +x = east) and pitch
    (degrees, positive = looking up)."""

    eye: tuple[float, float, float]
    yaw_deg: float
    pitch_deg: float

    def heading(self) -> NDArray[np.float64]:
        """Unit viewing direction [3] in the world frame."""
        yaw, pitch = np.radians(self.yaw_deg), np.radians(self.pitch_deg)
        return np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), np.sin(pitch)])

    def world_from_cam(self) -> NDArray[np.float64]:
        """Camera pose [4, 4], OpenCV axes (x right, y down, z forward), no roll."""
        eye = np.asarray(self.eye, np.float64)
        return look_at(eye, eye + self.heading())


def random_start(scene: VqaScene, config: VqaConfig, free, rng: np.random.Generator) -> AgentPose:
    """A random navigable pose: uniform in ``free`` (rejection sampling in its bounds), fixed eye height,
    uniform yaw, level gaze. Raises ``VqaInputError`` when no sample lands in the free space."""
    from shapely import contains_xy

    if free.is_empty:
        raise VqaInputError("no free floor space for the agent (room too small for the clearances)")
    x0, y0, x1, y1 = free.bounds
    n = config.max_view_attempts
    xy = np.column_stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)])
    yaw = rng.uniform(0.0, 360.0, n)
    inside = np.flatnonzero(contains_xy(free, xy[:, 0], xy[:, 1]))
    if len(inside) == 0:
        raise VqaInputError(f"no navigable start found in {n} samples (free floor area {free.area:.2f} m2)")
    i = int(inside[0])
    z = scene.floor_height() + config.walk_eye_height
    return AgentPose((float(xy[i, 0]), float(xy[i, 1]), float(z)), float(yaw[i]), 0.0)


def step(pose: AgentPose, action: str, config: VqaConfig, free, rng: np.random.Generator) -> tuple[AgentPose, str]:
    """Apply one action; returns the new pose and the action as executed (``blocked`` when a forward move
    would leave the free space, in which case the agent turns left or right at random)."""
    from shapely.geometry import LineString

    if action == "forward":
        yaw = np.radians(pose.yaw_deg)
        x, y, z = pose.eye
        nx, ny = x + config.walk_step_m * np.cos(yaw), y + config.walk_step_m * np.sin(yaw)
        if free.contains(LineString([(x, y), (nx, ny)])):
            return AgentPose((float(nx), float(ny), z), pose.yaw_deg, pose.pitch_deg), "forward"
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return AgentPose(pose.eye, (pose.yaw_deg + sign * config.walk_turn_deg) % 360.0, pose.pitch_deg), "blocked"
    if action in ("turn_left", "turn_right"):
        sign = 1.0 if action == "turn_left" else -1.0
        return AgentPose(pose.eye, (pose.yaw_deg + sign * config.walk_turn_deg) % 360.0, pose.pitch_deg), action
    if action in ("look_up", "look_down"):
        sign = 1.0 if action == "look_up" else -1.0
        lim = config.walk_look_max_deg
        pitch = float(np.clip(pose.pitch_deg + sign * config.walk_look_deg, -lim, lim))
        return AgentPose(pose.eye, pose.yaw_deg, pitch), action
    raise ValueError(f"unknown action {action!r}; actions: {', '.join(ACTIONS)}")


def walk_viewpoints(
    scene: VqaScene, config: VqaConfig, renderer: Renderer, rng: np.random.Generator
) -> tuple[list[Viewpoint], dict[int, RenderedFrame]]:
    """``config.walks`` egocentric walks of ``config.walk_steps`` actions each, a capture after every action.

    Returns the kept captures as viewpoints (ids 'view_000', ... in capture order; ``target`` is the object
    under the image centre, 0 for none) and their rendered frames (index in the list -> frame).
    """
    free = free_space(scene, config)
    K = intrinsics(config)
    probs = np.asarray(config.walk_action_probs, np.float64)
    probs = probs / probs.sum()
    views: list[Viewpoint] = []
    frames: dict[int, RenderedFrame] = {}
    for walk in range(config.walks):
        for _restart in range(WALK_RESTARTS + 1):
            kept = len(views)
            _one_walk(scene, config, renderer, rng, free, K, probs, walk, views, frames)
            if len(views) > kept:
                break
    return views, frames


def _one_walk(
    scene: VqaScene,
    config: VqaConfig,
    renderer: Renderer,
    rng: np.random.Generator,
    free,
    K: NDArray[np.float64],
    probs: NDArray[np.float64],
    walk: int,
    views: list[Viewpoint],
    frames: dict[int, RenderedFrame],
) -> None:
    """One walk from a random start; appends its captures that see an object to ``views`` and ``frames``."""
    pose = random_start(scene, config, free, rng)
    actions = [ACTIONS[int(k)] for k in rng.choice(len(ACTIONS), size=config.walk_steps, p=probs)]
    for k, action in enumerate(actions):
        pose, done = step(pose, action, config, free, rng)
        camera = Camera(K, pose.world_from_cam(), config.image_width, config.image_height)
        frame = renderer.render(camera)
        visible = visible_objects(frame.ids, config.min_visible_pixels)
        if not visible:
            continue
        h, w = frame.ids.shape
        centre_id = max(int(frame.ids[h // 2, w // 2]), 0)
        ids, counts = np.unique(frame.ids[frame.ids > 0], return_counts=True)
        faint = {int(i): int(n) for i, n in zip(ids, counts, strict=True) if n < config.min_visible_pixels}
        agent = {
            "walk": walk,
            "step": k,
            "action": done,
            "yaw_deg": round(pose.yaw_deg, 3),
            "pitch_deg": round(pose.pitch_deg, 3),
        }
        vp = Viewpoint(f"view_{len(views):03d}", centre_id, camera, visible, centre_id, faint=faint, agent=agent)
        frames[len(views)] = frame
        views.append(vp)
