import json

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from rescene_core.config import RegistrationConfig
from rescene_core.geometry import sim3
from rescene_core.records import Asset, InstanceId, InstancePoints, Missing, Pose
from rescene_core.registration import add_s, gates, pipeline, register, register_detailed
from rescene_core.registration import candidates as candidates_module
from rescene_core.registration import refinement as refinement_module
from rescene_core.registration.bounded_icp import bounded_sim3_icp, umeyama
from tests.registration.fixtures import chair_mesh, random_world_from_object, scan, table_mesh, unit_box_asset

CONFIG = RegistrationConfig()


def _errors(pose, asset, world_from_asset_gt, mesh):
    diam = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    x = asset.vertices
    adds = add_s(sim3.apply(world_from_asset_gt, x), sim3.apply(pose.world_from_asset, x)) / diam
    scale_err = abs(sim3.parts_from_sim3(pose.world_from_asset)[0] / sim3.parts_from_sim3(world_from_asset_gt)[0] - 1)
    return adds, scale_err


def _case(mesh, seed, partial, scale=1.3, noise=0.004):
    rng = np.random.default_rng(seed)
    hidden = random_world_from_object(rng, 15)
    hidden[:3, :3] *= scale
    asset, asset_from_object = unit_box_asset(mesh, hidden)
    world_from_object = random_world_from_object(rng, 0)
    target = scan(mesh, world_from_object, rng, partial=partial, noise=noise)
    return asset, target, sim3.compose(world_from_object, sim3.inverse(asset_from_object))


def test_recovers_known_sim3_on_full_noisy_cloud():
    mesh = chair_mesh()
    asset, target, gt = _case(mesh, seed=3, partial=False)
    pose = register(asset, target, CONFIG)
    assert isinstance(pose, Pose), pose
    adds, scale_err = _errors(pose, asset, gt, mesh)
    assert adds < 0.02, pose.diagnostics["final"]
    assert scale_err < 0.02
    assert pose.method == "bounded_sim3_icp"


def test_recovers_known_sim3_on_partial_noisy_cloud():
    mesh = table_mesh()
    asset, target, gt = _case(mesh, seed=1, partial=True, scale=0.7)
    pose = register(asset, target, CONFIG)
    assert isinstance(pose, Pose), pose
    adds, scale_err = _errors(pose, asset, gt, mesh)
    assert adds < 0.05, pose.diagnostics["final"]
    assert scale_err < 0.05


def test_diagnostics_record_every_gate_and_are_json():
    asset, target, _ = _case(chair_mesh(), seed=3, partial=False)
    pose = register(asset, target, CONFIG)
    d = json.loads(json.dumps(pose.to_json()))["diagnostics"]
    assert d["init"]["candidates"], "no initialisation candidate recorded"
    for cand in d["init"]["candidates"]:
        assert "accepted" in cand or cand["source"] == "normalisation"
    assert {"accepted", "reasons", "fit", "init_fit", "scale_vs_init", "refinement_rotation_deg"} <= set(
        d["refinement"]
    )
    assert d["final"]["fit"]["inlier_ratio"] >= CONFIG.min_result_inlier_ratio


def _icp_case(scale: float, yaw_deg: float):
    """(source samples, target points, init, target extent) for the bounded ICP on the full chair cloud, with
    an initialisation ``yaw_deg`` of yaw and ``scale`` x scale away from the truth, about the object's centre."""
    asset, target, gt = _case(chair_mesh(), seed=5, partial=False)
    points = np.asarray(target.points, np.float64)
    centre = sim3.sim3_from_parts(1.0, np.eye(3), points.mean(axis=0))
    off = sim3.sim3_from_parts(scale, Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix(), np.zeros(3))
    init = sim3.compose(centre, sim3.compose(off, sim3.compose(sim3.inverse(centre), gt)))
    source = trimesh.sample.sample_surface(trimesh.Trimesh(asset.vertices, asset.faces), 3000, seed=0)[0]
    extent = float(np.linalg.norm(np.ptp(points, axis=0)))
    return source, points, init, extent


def test_icp_respects_rotation_and_scale_bounds():
    source, points, init, extent = _icp_case(scale=1.4, yaw_deg=40)
    result = bounded_sim3_icp(source, points, init, extent, CONFIG)
    assert result.history
    assert max(h["step_rotation_deg"] for h in result.history) <= CONFIG.max_step_rotation_deg + 1e-6
    s0, rot0, _ = sim3.parts_from_sim3(init)
    s, rot, _ = sim3.parts_from_sim3(result.world_from_asset)
    assert np.rad2deg(sim3.rotation_angle(rot @ rot0.T)) <= CONFIG.max_total_rotation_deg + 1e-6
    assert CONFIG.scale_min - 1e-9 <= s / s0 <= CONFIG.scale_max + 1e-9
    # the truth is 1/1.4 away in scale: the scale bound must have been active
    assert result.scale_clips > 0


@pytest.mark.parametrize("bound", ["step", "total"])
def test_rotation_clamps_engage(bound):
    source, points, init, extent = _icp_case(scale=1.0, yaw_deg=12)
    limit = {"max_step_rotation_deg": 0.5} if bound == "step" else {"max_total_rotation_deg": 4.0}
    config = CONFIG.model_copy(update=limit)
    result = bounded_sim3_icp(source, points, init, extent, config)
    _, rot0, _ = sim3.parts_from_sim3(init)
    _, rot, _ = sim3.parts_from_sim3(result.world_from_asset)
    total = np.rad2deg(sim3.rotation_angle(rot @ rot0.T))
    assert max(h["step_rotation_deg"] for h in result.history) <= config.max_step_rotation_deg + 1e-6
    assert total <= config.max_total_rotation_deg + 1e-6
    if bound == "step":
        assert result.step_clamps > 0
    else:
        assert result.total_clamps > 0 and total > 3.9


def test_wild_scale_candidate_is_rejected_by_the_init_gate(monkeypatch):
    asset, target, gt = _case(chair_mesh(), seed=3, partial=False)
    wild = sim3.compose(gt, sim3.sim3_from_parts(5.0, np.eye(3), np.zeros(3)))
    monkeypatch.setattr(candidates_module, "fpfh_ransac_candidates", lambda *a, **k: [wild])
    pose, diag = register_detailed(asset, target, CONFIG)
    cand = diag.init.candidates[0]
    assert not cand.gate.accepted
    assert any("scale" in r for r in cand.gate.reasons)
    assert diag.init.candidates[-1].source == "normalisation"
    if isinstance(pose, Pose):
        s = sim3.parts_from_sim3(pose.world_from_asset)[0] / sim3.parts_from_sim3(gt)[0]
        assert 0.5 < s < 2.0


def test_solver_failure_falls_back_to_conservative_icp(monkeypatch):
    asset, target, _ = _case(chair_mesh(), seed=3, partial=False)

    def broken(*args, **kwargs):
        raise FloatingPointError("solver blew up")

    monkeypatch.setattr(refinement_module, "bounded_sim3_icp", broken)
    pose, diag = register_detailed(asset, target, CONFIG)
    assert "solver blew up" in diag.refinement.error
    assert diag.refinement.refined is not None and diag.refinement.refined.method == "fallback_nn_icp"
    assert isinstance(pose, Pose)
    assert pose.method in {"fallback_nn_icp", "init_only"}


def test_a_defect_in_the_solver_raises_instead_of_falling_back(monkeypatch):
    """Only numerical solver failures fall back; any other exception is a bug and reaches the caller."""
    asset, target, _ = _case(chair_mesh(), seed=3, partial=False)

    def buggy(*args, **kwargs):
        raise TypeError("a defect")

    monkeypatch.setattr(refinement_module, "bounded_sim3_icp", buggy)
    with pytest.raises(TypeError, match="a defect"):
        register_detailed(asset, target, CONFIG)


def test_typed_diagnostics_are_what_pose_json_holds():
    asset, target, _ = _case(chair_mesh(), seed=3, partial=False)
    pose, diag = register_detailed(asset, target, CONFIG)
    assert isinstance(pose, Pose)
    assert json.loads(json.dumps(pose.diagnostics)) == json.loads(json.dumps(diag.to_json()))
    assert diag.final is not None and pose.diagnostics["final"]["init"] == diag.final.init


def _asset(vertices, faces):
    return Asset(InstanceId(3), np.asarray(vertices, np.float64), np.asarray(faces, np.int64), "gt")


def _target(points):
    points = np.asarray(points, np.float32)
    return InstancePoints(InstanceId(3), points, np.zeros((len(points), 3), np.uint8))


@pytest.fixture(scope="module")
def good():
    asset, target, _ = _case(chair_mesh(), seed=3, partial=False)
    return asset, target


def test_rejects_nan_vertices(good):
    asset, target = good
    v = asset.vertices.copy()
    v[5] = np.nan
    out = register(_asset(v, asset.faces), target, CONFIG)
    assert isinstance(out, Missing) and out.stage == "registration" and "non-finite" in out.reason


def test_rejects_nan_target(good):
    asset, target = good
    p = np.asarray(target.points).copy()
    p[10, 1] = np.nan
    out = register(asset, _target(p), CONFIG)
    assert isinstance(out, Missing) and "non-finite" in out.reason


def test_rejects_too_few_points(good):
    asset, target = good
    out = register(asset, _target(np.asarray(target.points)[: CONFIG.min_correspondences - 1]), CONFIG)
    assert isinstance(out, Missing) and "points" in out.reason


def test_rejects_mesh_without_faces(good):
    asset, target = good
    out = register(_asset(asset.vertices, np.zeros((0, 3))), target, CONFIG)
    assert isinstance(out, Missing) and "no faces" in out.reason


@pytest.mark.parametrize("kind", ["planar", "collinear"])
def test_rejects_degenerate_targets(good, kind):
    asset, _ = good
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, size=(500, 3))
    p[:, 2] = 0.0
    if kind == "collinear":
        p[:, 1] = 0.0
    out = register(asset, _target(p + [1.0, 2.0, 0.5]), CONFIG)
    assert isinstance(out, Missing) and kind in out.reason


def test_umeyama_recovers_exact_similarity():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(100, 3))
    rot = Rotation.random(random_state=1).as_matrix()
    b = 1.7 * a @ rot.T + [1.0, -2.0, 0.3]
    s, r = umeyama(a, b)
    assert abs(s - 1.7) < 1e-9
    np.testing.assert_allclose(r, rot, atol=1e-9)


def picture_mesh() -> trimesh.Trimesh:
    """A flat wall picture (0.6 x 0.03 x 0.45 m) with a deeper bottom rail, so its in-plane rotation is visible."""
    panel = trimesh.creation.box((0.6, 0.03, 0.45), trimesh.transformations.translation_matrix((0, 0, 0.225)))
    rail = trimesh.creation.box((0.6, 0.06, 0.04), trimesh.transformations.translation_matrix((0, 0.015, 0.02)))
    return trimesh.util.concatenate([panel, rail])


def _in_plane_turned(world_from_asset, asset, angle_deg):
    """The pose turned by angle_deg about the posed picture's normal (world), about the posed asset's centre."""
    s, rot, t = sim3.parts_from_sim3(world_from_asset)
    centre = 0.5 * (asset.vertices.min(axis=0) + asset.vertices.max(axis=0))
    normal = rot @ np.array([0.0, 1.0, 0.0])  # the picture's front in the world (no hidden tilt in these cases)
    turn = Rotation.from_rotvec(normal / np.linalg.norm(normal) * np.deg2rad(angle_deg)).as_matrix()
    pivot = s * rot @ centre + t
    return sim3.sim3_from_parts(s, turn @ rot, pivot - s * (turn @ rot) @ centre)


def _picture_case():
    mesh = picture_mesh()
    rng = np.random.default_rng(5)
    hidden = sim3.sim3_from_parts(1.4, Rotation.from_euler("z", 40, degrees=True).as_matrix(), np.zeros(3))
    asset, asset_from_object = unit_box_asset(mesh, hidden)
    world_from_object = sim3.sim3_from_parts(1.0, Rotation.from_euler("z", 130, degrees=True).as_matrix(), [1, 2, 1.2])
    target = scan(mesh, world_from_object, rng, partial=True, noise=0.003)
    return mesh, asset, target, sim3.compose(world_from_object, sim3.inverse(asset_from_object))


def test_upright_snap_undoes_an_in_plane_turn():
    _, asset, _, gt = _picture_case()
    turned = _in_plane_turned(gt, asset, 70.0)
    assert gates.rotation_gate_angle(turned, None) > 60.0
    centre = 0.5 * (asset.vertices.min(axis=0) + asset.vertices.max(axis=0))
    snapped = gates.upright_snap(turned, centre)
    np.testing.assert_allclose(snapped, gt, atol=1e-9)
    upside_down = _in_plane_turned(gt, asset, 180.0)
    assert gates.upright_snap(upside_down, centre) is None


@pytest.mark.parametrize("snap", [True, False])
def test_flat_picture_keeps_its_in_plane_rotation(monkeypatch, snap):
    """RANSAC on a flat object fits the plane but may turn it in-plane; the tilt gate rejects that candidate.
    With upright_snap the turned candidate is set upright and wins; without it the picture is lost."""
    mesh, asset, target, gt = _picture_case()
    turned = _in_plane_turned(gt, asset, 65.0)
    monkeypatch.setattr(candidates_module, "fpfh_ransac_candidates", lambda *a, **k: [turned])
    config = RegistrationConfig(upright_snap=snap)
    pose, diag = register_detailed(asset, target, config)
    first = diag.init.candidates[0]
    assert not first.gate.accepted and all("rotation gate" in r for r in first.gate.reasons)
    if snap:
        assert isinstance(pose, Pose), pose
        assert diag.final.init == "fpfh_ransac[0]+upright"
        adds, scale_err = _errors(pose, asset, gt, mesh)
        assert adds < 0.03 and scale_err < 0.03
        assert gates.rotation_gate_angle(pose.world_from_asset, None) < 5.0
    else:
        assert all(c.source != "fpfh_ransac[0]+upright" for c in diag.init.candidates)
        assert isinstance(pose, Missing) or _errors(pose, asset, gt, mesh)[0] > 0.05


def test_ransac_restarts_stop_early_once_a_candidate_fits():
    asset, target, gt = _case(chair_mesh(), seed=3, partial=False)
    _, eager = register_detailed(asset, target, CONFIG)
    first = eager.init.candidates[0]
    assert eager.search.restarts_run == 1 and first.gate.accepted
    assert first.fit.inlier_ratio >= CONFIG.ransac_early_exit_inlier_ratio
    _, full = register_detailed(asset, target, CONFIG.model_copy(update={"ransac_early_exit_inlier_ratio": 1.1}))
    assert full.search.restarts_run == CONFIG.ransac_restarts


def test_only_the_best_probe_gets_the_full_refinement(monkeypatch):
    mesh = chair_mesh()
    asset, target, gt = _case(mesh, seed=3, partial=False)
    near = sim3.compose(sim3.sim3_from_parts(1.03, Rotation.from_rotvec([0, 0, 0.1]).as_matrix(), np.zeros(3)), gt)
    off = sim3.compose(sim3.sim3_from_parts(1.0, Rotation.from_rotvec([0, 0, 0.2]).as_matrix(), np.zeros(3)), gt)
    monkeypatch.setattr(candidates_module, "fpfh_ransac_candidates", lambda *a, **k: [off, near])
    pose, diag = register_detailed(asset, target, CONFIG.model_copy(update={"ransac_early_exit_inlier_ratio": 1.1}))
    cands = [c for c in diag.init.candidates if c.gate.accepted]
    assert len(cands) == 2 and all(c.probe_fit is not None for c in cands)
    assert [(c.refined_fit is not None) for c in cands] == [False, True]
    assert diag.final.init == "fpfh_ransac[1]"
    solver = diag.refinement.solver
    assert solver.iterations > CONFIG.probe_iterations or solver.stop_reason == "converged"
    adds, scale_err = _errors(pose, asset, gt, mesh)
    assert adds < 0.02 and scale_err < 0.02


def test_shared_feature_matches_give_the_feature_matching_ransac_candidates():
    """Matching FPFH once per instance changes no candidate: restarts on the shared matches equal Open3D's
    feature-matching RANSAC (mutual filter) with the same seeds, bit for bit."""
    import open3d as o3d

    from rescene_core.registration.init import Normalisation, _prepare, fpfh_ransac_candidates

    reg = o3d.pipelines.registration
    asset, target, _ = _case(table_mesh(), seed=1, partial=True, scale=0.7)
    source = pipeline.sample_source(asset, CONFIG)
    tgt = pipeline.prepare_target(np.asarray(target.points, np.float64), CONFIG)
    sn, tn = Normalisation.of(source), Normalisation.of(tgt)
    config = CONFIG.model_copy(update={"ransac_restarts": 2, "ransac_iterations": 500})
    shared = fpfh_ransac_candidates(source, tgt, sn, tn, config)
    src_down, src_feat = _prepare(sim3.apply(sn.normalised_from_frame, source), config.voxel_ratio, config)
    tgt_down, tgt_feat = _prepare(sim3.apply(tn.normalised_from_frame, tgt), config.voxel_ratio, config)
    distance = config.ransac_distance_voxels * config.voxel_ratio
    direct = []
    for restart in range(config.ransac_restarts):
        o3d.utility.random.seed(config.seed + restart)
        result = reg.registration_ransac_based_on_feature_matching(
            src_down,
            tgt_down,
            src_feat,
            tgt_feat,
            True,
            distance,
            reg.TransformationEstimationPointToPoint(True),
            3,
            [
                reg.CorrespondenceCheckerBasedOnEdgeLength(config.ransac_edge_length),
                reg.CorrespondenceCheckerBasedOnDistance(distance),
            ],
            reg.RANSACConvergenceCriteria(config.ransac_iterations, config.ransac_confidence),
        )
        tn_from_sn = np.asarray(result.transformation)
        direct.append(sim3.compose(tn.frame_from_normalised, sim3.compose(tn_from_sn, sn.normalised_from_frame)))
    assert len(shared) == len(direct) == 2
    for a, b in zip(shared, direct, strict=True):
        np.testing.assert_array_equal(a, b)


def test_icp_resumed_from_a_probe_equals_one_uninterrupted_run():
    source, points, init, extent = _icp_case(scale=1.2, yaw_deg=30)
    config = CONFIG.model_copy(update={"icp_tolerance": 0.0})  # run the whole budget
    direct = bounded_sim3_icp(source, points, init, extent, config)
    probe_config = config.model_copy(update={"max_iterations": config.probe_iterations})
    probe = bounded_sim3_icp(source, points, init, extent, probe_config)
    assert probe.iterations == config.probe_iterations and probe.stop_reason == "max_iterations"
    resumed = bounded_sim3_icp(source, points, init, extent, config, resume=probe)
    assert direct.iterations == resumed.iterations == config.max_iterations
    np.testing.assert_array_equal(direct.world_from_asset, resumed.world_from_asset)
    assert direct.history == resumed.history
    assert (direct.step_clamps, direct.total_clamps, direct.scale_clips) == (
        resumed.step_clamps,
        resumed.total_clamps,
        resumed.scale_clips,
    )
    # a probe that already stopped (converged) is the final result
    done = bounded_sim3_icp(source, points, init, extent, CONFIG)
    if done.stop_reason != "max_iterations":
        assert bounded_sim3_icp(source, points, init, extent, CONFIG, resume=done) is done
