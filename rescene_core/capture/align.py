"""Gravity and floor alignment of a recording: the world rotated to z up with the floor at z = 0.

Real recorders keep their own world axes (a HoloLens or ARKit world is y up; ScanNet's is z up with the
floor anywhere), and head-mounted or hand-held cameras look down at what they record: a camera pitched
60 deg down and rolled 30 deg has its up (minus its image y axis) 64 deg from gravity. Up comes from one of
two priors:

- the device's own gravity (``up``: an IMU vector given with ``rescene import --up`` or read from the
  source's layout), refined by the floor plane when one lies within ``gravity_max_tilt_deg`` of it;
- otherwise the fused points alone: planes are peeled off by RANSAC and each is counted by the inliers
  whose local normal agrees with it (a floor seen in separate patches is still one plane). The floor is a
  large plane that has the cameras above it, held at a plausible roll over it (over a wall they would be
  rolled 90 deg), and almost nothing below it, within ``max_tilt_deg`` of the cameras' mean up; among
  several such planes a lower parallel one wins (the others are furniture tops), and the cameras' mean up
  only breaks what is left of a tie.

``estimate_alignment`` rotates the floor normal to +z, turns the dominant wall direction onto the x axis
and puts the floor at z = 0. When no plane qualifies and no gravity was given it falls back to the
cameras' mean up (``method: cameras``) and its ``warning`` says so, with every plane tried, why each was
rejected and which ``--up`` to give. The transform ``aligned_from_source`` is kept in the capture's
attributes so that every output maps back to the source frame (``source_from_aligned`` = its inverse).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict

from rescene_core.geometry.open3d_rng import seeded_open3d_rng


class AlignConfig(BaseModel):
    """Floor and gravity finding. Lengths in metres, angles in degrees (paper-silent: the capture side)."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    voxel: float = 0.04
    """Voxel size the fused points are thinned to before plane fitting (m)."""
    ransac_distance: float = 0.03
    """RANSAC inlier distance of a plane (m)."""
    ransac_iterations: int = 1000
    """RANSAC iterations per plane."""
    ransac_sample: int = 10000
    """Most points RANSAC draws its hypotheses from (a random subset); inliers are counted on all."""
    max_planes: int = 12
    """Most planes peeled off the points while looking for the floor (walls, furniture sides and tops
    come off before a floor seen only in patches)."""
    normal_agreement_deg: float = 30.0
    """An inlier counts towards a plane only when its local normal is within this angle of the plane's
    (a plane cutting through clutter collects inliers, not support)."""
    max_tilt_deg: float = 80.0
    """Largest angle between the floor normal and the cameras' mean up when no gravity is given (deg): a
    camera pitched 60 deg down and rolled 30 deg has its up 64 deg from gravity."""
    max_camera_roll_deg: float = 45.0
    """Largest roll a camera is held at over a floor (deg): gravity's direction in the image, measured from
    the image's down axis. Over a wall a camera would be rolled 90 deg, over the ceiling 180 deg."""
    gravity_max_tilt_deg: float = 10.0
    """Largest angle between the floor normal and a given gravity up (deg); beyond it the gravity stands."""
    min_floor_area: float = 0.25
    """Least area a floor candidate's points cover, its patches together (m^2; points x voxel^2)."""
    min_floor_fraction: float = 0.005
    """Least share of the thinned points a floor candidate holds (its patches together)."""
    min_camera_height: float = 0.3
    """A camera stands at least this far above the floor (m)."""
    max_camera_height: float = 3.5
    """A camera stands at most this far above the floor (m)."""
    min_cameras_above: float = 0.8
    """Least share of the cameras between ``min_camera_height`` and ``max_camera_height`` above a floor,
    and held within ``max_camera_roll_deg`` of level over it."""
    below_tolerance: float = 0.10
    """Points further than this under a candidate plane count as below it (m)."""
    max_below_fraction: float = 0.03
    """Largest share of the thinned points below a floor (depth noise, reflections); a furniture top has
    the floor and its own sides below it."""
    parallel_deg: float = 10.0
    """Two floor candidates within this angle are parallel: the lower one is the floor."""
    refine_band: float = 0.02
    """Half-width of the slab the floor plane is refitted to by least squares (m)."""
    yaw: bool = True
    """Turn the dominant wall direction onto the x axis (plans and exports read better)."""
    seed: int = 0
    """Seed of Open3D's RANSAC and of the subset it draws from."""


@dataclass(frozen=True)
class PlaneCandidate:
    """A plane peeled off the fused points and what the floor tests said of it.

    normal: unit [3] in the source frame, oriented towards the cameras. offset: d of n . x + d = 0 (m).
    support: thinned points on the plane whose local normal agrees. tilt_deg: angle to the prior up (deg).
    camera_height: median height of the camera centres above the plane (m). cameras_above: share of the
    cameras at a floor's height above it. cameras_level: share of the cameras held within the roll limit
    over it. below_fraction: share of the thinned points under it.
    failed: the floor tests it failed, by name ('size', 'tilt', 'cameras', 'roll', 'below'; empty: it passed them
    all). verdict: 'floor', or why it is not the floor, in words.
    """

    normal: NDArray[np.float64]
    offset: float
    support: int
    tilt_deg: float
    camera_height: float
    cameras_above: float
    cameras_level: float
    below_fraction: float
    failed: tuple[str, ...] = ()
    verdict: str = ""

    def to_json(self) -> dict[str, Any]:
        return {
            "normal_source": [round(float(v), 5) for v in self.normal],
            "offset_m": round(float(self.offset), 4),
            "support": int(self.support),
            "tilt_deg": round(float(self.tilt_deg), 2),
            "camera_height_m": round(float(self.camera_height), 3),
            "cameras_above": round(float(self.cameras_above), 3),
            "cameras_level": round(float(self.cameras_level), 3),
            "below_fraction": round(float(self.below_fraction), 4),
            "failed": list(self.failed),
            "verdict": self.verdict,
        }


@dataclass(frozen=True)
class Alignment:
    """The transform into the aligned frame and how it was found.

    aligned_from_source: float64 [4, 4] rigid. floor_normal_source: unit [3] floor normal in the source
    frame (up). camera_up_source: unit [3] the cameras' mean up in the source frame. method: 'floor' (a
    floor plane found from the cameras' prior), 'gravity+floor' (the given gravity refined by the floor
    plane), 'gravity' (the given gravity; no floor plane near it, the floor height from the lowest points),
    'cameras' (fallback: no floor plane and no gravity, the cameras' up and the lowest points) or 'none'.
    prior_up_source: unit [3] the up the search started from (the given gravity or the cameras' up);
    gravity_from: where the given gravity came from ('' when none). floor_inliers: points on the floor
    plane. floor_residual: RMS distance of those inliers to the plane (m). candidates: the planes tried.
    warning: what the user must know about this alignment ('' when nothing).
    """

    aligned_from_source: NDArray[np.float64]
    floor_normal_source: NDArray[np.float64]
    camera_up_source: NDArray[np.float64]
    method: str
    floor_inliers: int = 0
    floor_residual: float = 0.0
    yaw_deg: float = 0.0
    prior_up_source: NDArray[np.float64] | None = None
    gravity_from: str = ""
    max_tilt_deg: float = 0.0
    candidates: tuple[PlaneCandidate, ...] = ()
    warning: str = ""

    @property
    def source_from_aligned(self) -> NDArray[np.float64]:
        return rigid_inverse(self.aligned_from_source)

    @property
    def camera_up_angle_deg(self) -> float:
        """Angle between the floor normal and the cameras' mean up (deg)."""
        return angle_deg(self.floor_normal_source, self.camera_up_source)

    @property
    def prior_up_angle_deg(self) -> float:
        """Angle between the floor normal and the prior up (deg)."""
        prior = self.camera_up_source if self.prior_up_source is None else self.prior_up_source
        return angle_deg(self.floor_normal_source, prior)

    def to_json(self) -> dict[str, Any]:
        prior = self.camera_up_source if self.prior_up_source is None else self.prior_up_source
        return {
            "aligned_from_source": self.aligned_from_source.tolist(),
            "source_from_aligned": self.source_from_aligned.tolist(),
            "floor_normal_source": self.floor_normal_source.tolist(),
            "camera_up_source": self.camera_up_source.tolist(),
            "prior_up_source": np.asarray(prior).tolist(),
            "prior": "gravity" if self.gravity_from else "cameras",
            "gravity_from": self.gravity_from,
            "floor_to_camera_up_deg": round(self.camera_up_angle_deg, 3),
            "floor_to_prior_up_deg": round(self.prior_up_angle_deg, 3),
            "max_tilt_deg": round(float(self.max_tilt_deg), 3),
            "method": self.method,
            "floor_inliers": int(self.floor_inliers),
            "floor_residual_m": round(float(self.floor_residual), 5),
            "yaw_deg": round(float(self.yaw_deg), 3),
            "candidates": [c.to_json() for c in self.candidates],
            "warning": self.warning,
        }


def rigid_inverse(a_from_b: NDArray) -> NDArray[np.float64]:
    out = np.eye(4)
    rot = np.asarray(a_from_b, np.float64)[:3, :3]
    out[:3, :3] = rot.T
    out[:3, 3] = -rot.T @ np.asarray(a_from_b, np.float64)[:3, 3]
    return out


def angle_deg(a: NDArray, b: NDArray) -> float:
    """Angle between two unit vectors [3] (deg)."""
    return float(np.degrees(np.arccos(np.clip(float(np.asarray(a) @ np.asarray(b)), -1.0, 1.0))))


def unit_up(up: Any) -> NDArray[np.float64]:
    """A given up direction as a unit vector [3]; ValueError when it is not three finite numbers or zero."""
    v = np.asarray(up, np.float64).ravel()
    if v.shape != (3,) or not np.isfinite(v).all() or np.linalg.norm(v) < 1e-9:
        raise ValueError(f"an up direction is three finite numbers, not all zero (got {np.asarray(up).tolist()})")
    return v / np.linalg.norm(v)


def camera_up(world_from_cam: NDArray) -> NDArray[np.float64]:
    """The cameras' mean up direction [3] (minus the image y axis, OpenCV cameras), unit."""
    up = -np.asarray(world_from_cam, np.float64)[:, :3, 1].mean(axis=0)
    n = np.linalg.norm(up)
    if n < 1e-6:
        raise ValueError("the cameras' up directions cancel out; cannot tell where up is")
    return up / n


def nearest_axis(v: NDArray) -> tuple[str, float]:
    """The signed axis of the source frame nearest a unit vector [3], as ``--up`` text ('0,1,0'), and the
    angle to it (deg)."""
    k = int(np.argmax(np.abs(v)))
    axis = np.zeros(3)
    axis[k] = np.sign(v[k]) or 1.0
    return ",".join(str(int(a)) for a in axis), angle_deg(v, axis)


def rotation_between(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """The smallest rotation [3, 3] taking unit vector a onto unit vector b."""
    a = np.asarray(a, np.float64) / np.linalg.norm(a)
    b = np.asarray(b, np.float64) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1 + 1e-12:  # opposite: a half turn about any axis perpendicular to a
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


def _fit_plane(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], float, float]:
    """Least-squares plane of points [n, 3]: unit normal, offset d (n.x + d = 0), RMS residual."""
    c = points.mean(axis=0)
    _, s, vt = np.linalg.svd(points - c, full_matrices=False)
    n = vt[2]
    return n, float(-n @ c), float(s[2] / np.sqrt(max(len(points), 1)))


def _dominant_yaw(normals: NDArray[np.float64]) -> float:
    """Angle (rad) of the dominant horizontal normal direction modulo 90 deg (walls, furniture sides);
    normals [n, 3] in the z-up frame."""
    side = np.abs(normals[:, 2]) < 0.2
    if side.sum() < 50:
        return 0.0
    ang = np.arctan2(normals[side, 1], normals[side, 0])
    w = np.hypot(normals[side, 0], normals[side, 1])
    return float(np.angle(np.sum(w * np.exp(4j * ang))) / 4.0)


def _held_level(cam_x: NDArray, cam_down: NDArray, up: NDArray, max_roll_deg: float) -> NDArray[np.bool_]:
    """Which cameras [T] would be held within ``max_roll_deg`` of level were ``up`` [3] the true up: the
    roll is the angle of up in the image plane from the image's up axis. A camera looking within 10 deg of
    straight down (or up) has no roll to speak of and counts as level."""
    across, along = cam_x @ up, -(cam_down @ up)
    roll = np.degrees(np.arctan2(np.abs(across), along))
    return (np.hypot(across, along) < np.sin(np.radians(10.0))) | (roll <= max_roll_deg)


def _peel_planes(
    thin: NDArray[np.float64],
    normals: NDArray[np.float64],
    poses: NDArray[np.float64],
    prior: NDArray[np.float64],
    max_tilt: float,
    cfg: AlignConfig,
) -> list[PlaneCandidate]:
    """Planes peeled off ``thin`` [n, 3] by RANSAC, largest first, each with the floor tests' verdict
    (empty when it passes every test)."""
    import open3d as o3d

    min_support = max(int(np.ceil(cfg.min_floor_area / cfg.voxel**2)), int(cfg.min_floor_fraction * len(thin)))
    cos_agree = np.cos(np.radians(cfg.normal_agreement_deg))
    centres, cam_x, cam_down = poses[:, :3, 3], poses[:, :3, 0], poses[:, :3, 1]
    rest = np.arange(len(thin))
    out: list[PlaneCandidate] = []
    rng = np.random.default_rng(cfg.seed)  # Open3D's engine is seeded by the caller (seeded_open3d_rng)
    for _ in range(cfg.max_planes):
        if len(rest) < max(3, min_support):
            break
        pick = rest if len(rest) <= cfg.ransac_sample else rng.choice(rest, cfg.ransac_sample, replace=False)
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(thin[pick]))
        (a, b, c, d), _ = pcd.segment_plane(cfg.ransac_distance, 3, cfg.ransac_iterations)
        n = np.array([a, b, c])
        norm = float(np.linalg.norm(n))
        n, d = n / norm, d / norm
        inl = np.flatnonzero(np.abs(thin[rest] @ n + d) < cfg.ransac_distance)
        if len(inl) < 3:
            break
        heights = centres @ n + d
        if np.median(heights) < 0:  # orient towards the cameras
            n, d, heights = -n, -d, -heights
        on = rest[inl]
        support = int((np.abs(normals[on] @ n) >= cos_agree).sum())
        tilt = angle_deg(n, prior)
        above = float(((heights >= cfg.min_camera_height) & (heights <= cfg.max_camera_height)).mean())
        below = float((thin @ n + d < -cfg.below_tolerance).mean())
        level = float(_held_level(cam_x, cam_down, n, cfg.max_camera_roll_deg).mean())
        reasons = {}
        if support < min_support:
            reasons["size"] = f"too small: {support} points on it, fewer than {min_support}"
        if tilt > max_tilt:
            reasons["tilt"] = (
                f"tilted {tilt:.1f} deg from the prior up, more than the {max_tilt:g} allowed (--max-tilt)"
            )
        if above < cfg.min_cameras_above:
            reasons["cameras"] = (
                f"not under the cameras: {above:.0%} of them stand {cfg.min_camera_height:g}-"
                f"{cfg.max_camera_height:g} m above it (median {float(np.median(heights)):.2f} m)"
            )
        if level < cfg.min_cameras_above:
            reasons["roll"] = (
                f"the cameras would be rolled over it: {level:.0%} of them are within {cfg.max_camera_roll_deg:g} deg "
                "of level (a wall or the ceiling)"
            )
        if below > cfg.max_below_fraction:
            reasons["below"] = (
                f"{below:.1%} of the points lie more than {cfg.below_tolerance:g} m below it "
                "(a furniture top, or a plane through the scene)"
            )
        height = float(np.median(heights))
        out.append(
            PlaneCandidate(
                normal=n,
                offset=float(d),
                support=support,
                tilt_deg=tilt,
                camera_height=height,
                cameras_above=above,
                cameras_level=level,
                below_fraction=below,
                failed=tuple(reasons),
                verdict="; ".join(reasons.values()),
            )
        )
        rest = np.delete(rest, inl)
    return out


def _choose_floor(candidates: list[PlaneCandidate], cfg: AlignConfig) -> tuple[int | None, list[PlaneCandidate]]:
    """The index of the floor among the candidates that passed every test, and the candidates with their
    final verdicts. A passing plane with a lower parallel passing plane is a furniture top; of the rest the
    one nearest the prior up is the floor."""
    passed = [k for k, c in enumerate(candidates) if not c.failed]
    verdicts = {k: c.verdict for k, c in enumerate(candidates)}
    cos_par = np.cos(np.radians(cfg.parallel_deg))
    for k in passed:
        lower = [
            j
            for j in passed
            if j != k
            and candidates[j].normal @ candidates[k].normal >= cos_par
            and candidates[j].camera_height > candidates[k].camera_height + cfg.below_tolerance
        ]
        if lower:
            below = candidates[k].camera_height - candidates[lower[0]].camera_height
            verdicts[k] = f"a parallel plane {abs(below):.2f} m lower qualifies too (this one is a furniture top)"
    left = [k for k in passed if not verdicts[k]]
    choice = min(left, key=lambda k: candidates[k].tilt_deg) if left else None
    for k in left:
        if k != choice and choice is not None:
            verdicts[k] = (
                f"qualifies, but {candidates[k].tilt_deg:.1f} deg from the prior up where the floor chosen is "
                f"{candidates[choice].tilt_deg:.1f} deg"
            )
    if choice is not None:
        verdicts[choice] = "floor"
    out = [dataclasses.replace(c, verdict=verdicts[k]) for k, c in enumerate(candidates)]
    return choice, out


def _no_floor_warning(
    candidates: list[PlaneCandidate], cam_up: NDArray[np.float64], max_tilt: float, n_points: int
) -> str:
    """The fallback's message: it tilts the scene, what was tried, why each plane was rejected, what to give."""
    axis, off = nearest_axis(cam_up)
    head = (
        "NO FLOOR FOUND: gravity falls back to the cameras' mean up (method: cameras), so the scene is tilted "
        "by however far the cameras look down or roll"
    )
    if not candidates:
        tried = f"no plane could be fitted to the {n_points} fused depth points"
    else:
        rows = [
            f"  plane {k + 1}: normal {np.round(c.normal, 3).tolist()}, {c.tilt_deg:.1f} deg from the cameras' up, "
            f"{c.support} points: {c.verdict}"
            for k, c in enumerate(candidates)
        ]
        tried = f"{len(candidates)} planes tried in {n_points} fused depth points:\n" + "\n".join(rows)
    floorish = [c for c in candidates if c.failed == ("tilt",)]
    never = not any(set(c.failed) <= {"tilt"} for c in candidates)
    lines = [head + ".", tried]
    if never:
        lines.append("The cameras never see a floor: no large plane lies under them with nothing below it.")
    y_up = "" if axis == "0,1,0" else "; y-up recorders such as HoloLens and ARKit: --up 0,1,0"
    lines.append(
        f"Fix: give the recorder's up in the source's world frame, e.g. --up {axis} (the source axis nearest "
        f"the cameras' mean up, {off:.0f} deg from it{y_up}), or its IMU gravity vector negated (Aria MPS "
        "gravity_world), or write the gravity vector to SRC/gravity.txt."
    )
    if floorish:
        best = min(floorish, key=lambda c: c.tilt_deg)
        lines.append(
            f"A plane at {best.tilt_deg:.1f} deg from the cameras' up was rejected only for its tilt: "
            f"--max-tilt {int(np.ceil(best.tilt_deg)) + 1} accepts it (now {max_tilt:g})."
        )
    return "\n".join(lines)


def estimate_alignment(
    points: NDArray,
    world_from_cam: NDArray,
    config: AlignConfig | None = None,
    up: NDArray | None = None,
    gravity_from: str = "--up",
) -> Alignment:
    """Find the floor in ``points`` [n, 3] (fused geometry, source frame) and the transform to z up.

    world_from_cam: [T, 4, 4] source-frame camera poses (OpenCV axes): the floor lies under them, and
    their mean up is the prior when no gravity is given. up: the device's up [3] in the source frame
    (minus its gravity), or None; gravity_from: where it came from (for the report).
    """
    import open3d as o3d

    cfg = config or AlignConfig()
    poses = np.asarray(world_from_cam, np.float64)
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if up is not None:
        prior = unit_up(up)
        max_tilt = cfg.gravity_max_tilt_deg
        try:
            cam_up = camera_up(poses)
        except ValueError:
            cam_up = prior
    else:
        cam_up = prior = camera_up(poses)
        max_tilt = cfg.max_tilt_deg
        gravity_from = ""
    centres = poses[:, :3, 3]
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts)).voxel_down_sample(cfg.voxel)
    thin = np.asarray(pcd.points)
    if len(thin) >= 10:
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=cfg.voxel * 3, max_nn=30))
        normals = np.asarray(pcd.normals)
    else:
        normals = np.zeros_like(thin)
    # Open3D's RANSAC on one thread with its seed held: on several threads one seed gave different planes
    # from call to call (the pose of a re-import moved by 4e-05), and a capture that differs misses every cache
    with seeded_open3d_rng(cfg.seed):
        peeled = _peel_planes(thin, normals, poses, prior, max_tilt, cfg)
    choice, candidates = _choose_floor(peeled, cfg)
    warning = ""
    if choice is None:
        # no floor plane: the prior up, and the floor at the 1st percentile of heights along it
        normal = prior
        height = float(np.percentile(thin @ prior, 1.0)) if len(thin) else float((centres @ prior).mean()) - 1.5
        inliers, resid = 0, 0.0
        if up is None:
            method = "cameras"
            warning = _no_floor_warning(candidates, cam_up, max_tilt, len(thin))
        else:
            method = "gravity"
            warning = (
                f"no floor plane within {max_tilt:g} deg of the given up ({gravity_from}): the up is kept as given "
                "and the floor height is the lowest 1% of the points along it"
            )
    else:
        c0 = candidates[choice]
        cos_agree = np.cos(np.radians(cfg.normal_agreement_deg))
        band = (np.abs(thin @ c0.normal + c0.offset) < cfg.refine_band) & (np.abs(normals @ c0.normal) >= cos_agree)
        normal, d, resid = _fit_plane(thin[band]) if band.sum() >= 3 else (c0.normal, c0.offset, 0.0)
        if normal @ c0.normal < 0:
            normal, d = -normal, -d
        height = -d
        inliers = int(band.sum())
        method = "floor" if up is None else "gravity+floor"
    rot = rotation_between(normal, [0.0, 0.0, 1.0])
    yaw = 0.0
    if cfg.yaw and len(thin) >= 50:
        yaw = _dominant_yaw(normals @ rot.T)
        cz, sz = np.cos(-yaw), np.sin(-yaw)
        rot = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]]) @ rot
    aligned_from_source = np.eye(4)
    aligned_from_source[:3, :3] = rot
    aligned_from_source[2, 3] = -height  # the floor's height along its normal becomes z = 0
    return Alignment(
        aligned_from_source=aligned_from_source,
        floor_normal_source=np.asarray(normal, np.float64),
        camera_up_source=cam_up,
        method=method,
        floor_inliers=inliers,
        floor_residual=float(resid),
        yaw_deg=float(np.degrees(yaw)),
        prior_up_source=prior,
        gravity_from=gravity_from,
        max_tilt_deg=max_tilt,
        candidates=tuple(candidates),
        warning=warning,
    )


def identity_alignment(world_from_cam: NDArray) -> Alignment:
    """No alignment (the source is already z up with its floor where it is)."""
    return Alignment(np.eye(4), np.array([0.0, 0.0, 1.0]), camera_up(world_from_cam), "none")


def apply_alignment(alignment: Alignment, world_from_cam: NDArray) -> NDArray[np.float64]:
    """Camera poses [T, 4, 4] in the aligned frame."""
    return np.einsum("ij,tjk->tik", alignment.aligned_from_source, np.asarray(world_from_cam, np.float64))


def transform_points(a_from_b: NDArray, points: NDArray) -> NDArray:
    """Points [n, 3] mapped by a rigid 4x4 (dtype kept)."""
    p = np.asarray(points)
    out = p.astype(np.float64) @ np.asarray(a_from_b)[:3, :3].T + np.asarray(a_from_b)[:3, 3]
    return out.astype(p.dtype)
