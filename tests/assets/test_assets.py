import numpy as np
import pytest
import trimesh

from rescene_core.assets import (
    BackendUnavailable,
    GeneratorInput,
    finish_asset,
    generate_asset,
    load_asset,
    save_asset,
)
from rescene_core.assets.lift import LiftBackend
from rescene_core.assets.sam3d import GLB_FROM_LOCAL, Sam3dBackend, convert_output, layout_pose
from rescene_core.config import AssetConfig
from rescene_core.geometry import sim3
from rescene_core.records import Asset, Camera, InstanceId, Missing, ViewChoice
from rescene_core.registration import add_s
from rescene_core.render import RayCaster, RenderMesh
from tests.registration.fixtures import chair_mesh

CONFIG = AssetConfig()


def look_at_camera(eye, target, width=160, height=120, f=140.0) -> Camera:
    """OpenCV camera at ``eye`` looking at ``target`` (world z up)."""
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x, y, z], axis=1)
    pose[:3, 3] = eye
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])
    return Camera(K, pose, width, height)


def render_view(mesh, camera) -> GeneratorInput:
    caster = RayCaster([RenderMesh.uniform(5, np.asarray(mesh.vertices), np.asarray(mesh.faces), (0.6, 0.5, 0.4))])
    hits = caster.cast_camera(camera)
    mask = hits.ids == 5
    rgb = np.zeros((camera.height, camera.width, 3), np.uint8)
    return GeneratorInput(InstanceId(5), "chair", 0, rgb, mask, camera, hits.depth.astype(np.float32))


@pytest.fixture(scope="module")
def chair_views():
    mesh = chair_mesh()
    full = look_at_camera(np.array([1.6, 2.2, 1.4]), np.array([0.0, 0.0, 0.45]))
    close = look_at_camera(np.array([0.45, 0.6, 0.9]), np.array([0.0, 0.0, 0.45]), f=320.0)
    return mesh, render_view(mesh, full), render_view(mesh, close)


def _completeness_error(asset: Asset, mesh) -> float:
    """Mean distance (fraction of the diagonal) from the true surface to the generated one, both in the world
    (the generated one placed by the backend's own canonicalisation, as recorded in its metadata)."""
    world_from_asset = sim3.compose(
        np.asarray(asset.metadata["world_from_generator"]), sim3.inverse(asset.asset_from_generator)
    )
    posed = trimesh.Trimesh(sim3.apply(world_from_asset, asset.vertices), asset.faces)
    truth = trimesh.sample.sample_surface(mesh, 1500, seed=0)[0]
    generated = trimesh.sample.sample_surface(posed, 6000, seed=0)[0]
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    return add_s(truth, generated) / diag


def test_lift_gives_watertight_unit_box_mesh(chair_views):
    mesh, full, _ = chair_views
    asset = finish_asset(InstanceId(5), "lift", LiftBackend(CONFIG).generate(full))
    tm = trimesh.Trimesh(asset.vertices, asset.faces)
    assert tm.is_watertight and tm.volume > 0
    lo, hi = asset.vertices.min(axis=0), asset.vertices.max(axis=0)
    assert abs(float((hi - lo).max()) - 1.0) < 1e-9
    np.testing.assert_allclose(0.5 * (lo + hi), 0.0, atol=1e-9)
    assert len(asset.faces) <= CONFIG.target_faces
    assert asset.metadata["watertight"] and not asset.metadata["mask_touches_border"]
    # the generator frame is upright: its z axis is world up
    world_from_generator = np.asarray(asset.metadata["world_from_generator"])
    np.testing.assert_allclose(world_from_generator[:3, 2], [0.0, 0.0, 1.0], atol=1e-9)


def test_lift_quality_depends_on_the_view(chair_views):
    mesh, full, close = chair_views
    backend = LiftBackend(CONFIG)
    good = finish_asset(InstanceId(5), "lift", backend.generate(full))
    bad = finish_asset(InstanceId(5), "lift", backend.generate(close))
    assert bad.metadata["mask_touches_border"]
    good_err, bad_err = _completeness_error(good, mesh), _completeness_error(bad, mesh)
    assert good_err < 0.06
    assert bad_err > 1.5 * good_err


def test_lift_without_depth_or_pixels_is_missing(chair_views):
    _, full, _ = chair_views

    class Cap:  # the Capture surface generate_asset reads
        num_frames = 1
        rgb = full.rgb[None]
        instance_masks = np.where(full.mask, 5, 0)[None]
        depth = None

        def instance(self, i):
            raise KeyError(i)

        def camera(self, t):
            return full.camera

    view = ViewChoice(InstanceId(5), 0, "test", "test")
    out = generate_asset(Cap(), view, CONFIG)
    assert isinstance(out, Missing) and out.stage == "asset" and "depth" in out.reason
    out = generate_asset(Cap(), ViewChoice(InstanceId(5), 3, "test", "test"), CONFIG)
    assert isinstance(out, Missing) and "frame" in out.reason
    Cap.depth = full.depth[None]
    Cap.instance_masks = np.zeros_like(Cap.instance_masks)
    out = generate_asset(Cap(), view, CONFIG)
    assert isinstance(out, Missing) and "pixels" in out.reason


def test_save_load_round_trip(tmp_path, chair_views):
    _, full, _ = chair_views
    asset = finish_asset(InstanceId(5), "lift", LiftBackend(CONFIG).generate(full))
    path = save_asset(tmp_path / "asset.glb", asset)
    back = load_asset(path, 5)
    assert back.backend == "lift" and back.instance == 5
    np.testing.assert_allclose(back.vertices, asset.vertices, atol=1e-6)
    np.testing.assert_array_equal(back.faces, asset.faces)
    np.testing.assert_allclose(back.asset_from_generator, asset.asset_from_generator)
    assert back.metadata["mask_pixels"] == asset.metadata["mask_pixels"]


def _fake_sam3d_output(local_mesh, quat_wxyz, translation, scale):
    glb = trimesh.Trimesh(local_mesh.vertices @ GLB_FROM_LOCAL.T, local_mesh.faces, process=False)
    return {
        "glb": glb,
        "rotation": np.asarray([quat_wxyz], np.float32),
        "translation": np.asarray([translation], np.float32),
        "scale": np.asarray([[scale] * 3], np.float32),
        "gaussian": [None],
    }


def test_sam3d_conversion_places_the_mesh_like_the_reference_code():
    from scipy.spatial.transform import Rotation

    local = trimesh.creation.box((0.4, 0.2, 0.6))
    local.apply_translation((0.1, 0.0, 0.3))
    q_xyzw = Rotation.from_euler("xyz", [20, -35, 50], degrees=True).as_quat()
    quat = [q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2]]
    t, s = [0.2, -0.1, 2.5], 1.7
    camera = look_at_camera(np.array([1.0, 2.0, 1.5]), np.array([0.0, 0.0, 0.5]))
    out = convert_output(_fake_sam3d_output(local, quat, t, s), camera)
    # reference: PyTorch3D row vectors p_cam = (s p) @ R + t, then PyTorch3D -> OpenCV axes, then world
    R = Rotation.from_quat(q_xyzw).as_matrix()
    p3d = (s * np.asarray(local.vertices)) @ R + t
    expected = sim3.apply(camera.world_from_cam, p3d * [-1.0, -1.0, 1.0])
    np.testing.assert_allclose(sim3.apply(out.world_from_generator_prior, out.vertices), expected, atol=1e-5)
    asset = finish_asset(InstanceId(4), "sam3d", out)
    pose = layout_pose(asset)
    assert pose is not None and pose.method == "sam3d_layout"
    posed = sim3.apply(pose.world_from_asset, asset.vertices)
    assert np.abs(np.sort(posed, axis=0) - np.sort(expected, axis=0)).max() < 1e-4
    assert abs(float(np.ptp(asset.vertices, axis=0).max()) - 1.0) < 1e-9


def test_sam3d_backend_names_what_is_missing(tmp_path):
    with pytest.raises(BackendUnavailable, match="sam3d_checkpoint"):
        Sam3dBackend(AssetConfig(backend="sam3d"))
    with pytest.raises(BackendUnavailable, match="not found"):
        Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path / "nope.yaml")))
    (tmp_path / "pipeline.yaml").write_text("{}\n")
    with pytest.raises(BackendUnavailable, match="SAM 3D Objects installed"):
        Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path)))
    with pytest.raises(BackendUnavailable, match="inference.py not found"):
        Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path), sam3d_code_dir=str(tmp_path)))


def test_sam3d_inference_loads_by_path_without_touching_sys_path(tmp_path):
    """The repository's notebook/inference.py is loaded from the clone; a missing SAM 3D install names the fix."""
    import sys

    (tmp_path / "pipeline.yaml").write_text("{}\n")
    clone = tmp_path / "clone"
    (clone / "notebook").mkdir(parents=True)
    (clone / "notebook" / "inference.py").write_text(
        "class Inference:\n    def __init__(self, config_file, compile=False):\n        self.config_file = config_file\n"
    )
    before = list(sys.path)
    backend = Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path), sam3d_code_dir=str(clone)))
    assert sys.path == before
    assert backend.inference.config_file == str(tmp_path / "pipeline.yaml")
    broken = tmp_path / "broken"
    (broken / "notebook").mkdir(parents=True)
    (broken / "notebook" / "inference.py").write_text("import sam3d_objects_not_installed_here\n")
    with pytest.raises(BackendUnavailable, match="pip install -e"):
        Sam3dBackend(AssetConfig(backend="sam3d", sam3d_checkpoint=str(tmp_path), sam3d_code_dir=str(broken)))
    assert sys.path == before


def _upright_extents(asset: Asset) -> tuple[float, float, float]:
    """(width, depth, height) in metres of the asset in its generator frame: the sides of the minimum-area
    rectangle around its footprint (longer, shorter) and its height (yaw-independent)."""
    from shapely.geometry import MultiPoint

    local = sim3.apply(sim3.inverse(asset.asset_from_generator), asset.vertices)
    rect = np.asarray(MultiPoint(local[:, :2]).convex_hull.minimum_rotated_rectangle.exterior.coords)[:4]
    sides = sorted([float(np.linalg.norm(rect[1] - rect[0])), float(np.linalg.norm(rect[2] - rect[1]))])
    return sides[1], sides[0], float(np.ptp(local[:, 2]))


def _posed_box(size, yaw_deg, centre):
    box = trimesh.creation.box(size)
    rotation = trimesh.transformations.rotation_matrix(np.radians(yaw_deg), [0, 0, 1])
    box.apply_transform(rotation)
    box.apply_translation(centre)
    return box


def _noisy(view: GeneratorInput, sigma: float, seed: int = 0) -> GeneratorInput:
    rng = np.random.default_rng(seed)
    depth = view.depth + np.where(view.depth > 0, rng.normal(0.0, sigma, view.depth.shape), 0.0)
    return GeneratorInput(
        view.instance, view.label, view.frame, view.rgb, view.mask, view.camera, depth.astype(np.float32)
    )


@pytest.mark.parametrize("sigma", [0.0, 0.01])
def test_lift_oblique_thin_panel_gives_a_thin_slab(sigma):
    # a TV-like panel 1.0 x 0.05 x 0.6 m on a wall, seen 50 degrees off its normal from above
    panel = _posed_box((1.0, 0.05, 0.6), 0.0, (0.0, 0.0, 1.2))
    eye = np.array([2.0 * np.sin(np.radians(50)), 2.0 * np.cos(np.radians(50)), 1.8])
    view = _noisy(render_view(panel, look_at_camera(eye, np.array([0.0, 0.0, 1.2]))), sigma)
    asset = finish_asset(InstanceId(5), "lift", LiftBackend(CONFIG).generate(view))
    width, depth, height = _upright_extents(asset)
    assert asset.metadata["shape"]["flat"] and asset.metadata["completion"]["kind"] == "flat_slab"
    assert depth / width < 0.2
    assert abs(width - 1.0) < 0.15 and abs(height - 0.6) < 0.1
    # the slab lies behind the visible face (towards the wall), its normal is the panel's
    facing = np.asarray(asset.metadata["shape"]["facing"])
    assert abs(float(facing @ [0.0, 1.0, 0.0])) > np.cos(np.radians(5))


@pytest.mark.parametrize("sigma", [0.0, 0.01])
def test_lift_box_at_45_degrees_has_a_plausible_depth(sigma):
    size = (0.8, 0.5, 0.6)
    box = _posed_box(size, 45.0, (0.0, 0.0, 0.3))
    eye = np.array([0.0, 2.4, 1.5])  # 45 degrees between the view and both visible faces
    view = _noisy(render_view(box, look_at_camera(eye, np.array([0.0, 0.0, 0.3]))), sigma)
    asset = finish_asset(InstanceId(5), "lift", LiftBackend(CONFIG).generate(view))
    width, depth, height = _upright_extents(asset)
    truth = size[1] / size[0]
    assert truth / 1.5 < depth / width < truth * 1.5
    assert abs(width - size[0]) < 0.15 and abs(height - size[2]) < 0.1
    # the mirror normal is one of the box's face normals, not the view direction
    assert asset.metadata["shape"]["method"] == "faces"
    facing = np.asarray(asset.metadata["shape"]["facing"])
    yaw = np.degrees(np.arctan2(facing[1], facing[0]))
    assert abs((yaw - 45.0 + 45.0) % 90.0 - 45.0) < 8.0
