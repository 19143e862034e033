"""Geometry metrics (MonoSDF / DP-Recon protocol) against cases with known answers and Open3D."""

from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest
import trimesh

from rescene_core.evaluation.geometry import (
    GeometryConfig,
    PointSet,
    compare,
    downsample,
    point_metrics,
    refuse,
    sample_meshes,
)
from rescene_core.records import Camera
from rescene_core.vqa.render import look_at

CFG = GeometryConfig()
DENSE = GeometryConfig(samples_per_m2=100000.0)


def _square(z: float = 0.0, tilt_deg: float = 0.0) -> trimesh.Trimesh:
    """A 1 m x 1 m square (two triangles) at height z, optionally tilted about x."""
    v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    m = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(tilt_deg), [1, 0, 0], [0, 0.5, 0]))
    m.apply_translation([0, 0, z])
    return m


def test_identical_meshes_are_perfect():
    box = trimesh.creation.box(extents=[1.0, 0.6, 0.8])
    pts = sample_meshes({1: box}, CFG)
    m = compare(pts, pts, CFG)
    assert m["chamfer"] == 0.0 and m["accuracy"] == 0.0 and m["completion"] == 0.0
    assert m["fscore@5cm"] == 1.0 and m["normal_consistency"] == pytest.approx(1.0)
    assert m["centre_offset"] == 0.0


def test_plane_shifted_3cm_along_its_normal():
    # Every reference point lies on z = 0 and every predicted point on z = s, so each distance is at
    # least s. The dense samples leave no 2 cm voxel of the square empty, so each voxel mean lies in its
    # own voxel and any point of the square is within a voxel diagonal (sqrt(2) * v) of a downsampled
    # point: each distance is at most sqrt(s^2 + 2 v^2) = 4.12 cm < 5 cm. Hence F@5 = 1, F@2 = 0 and
    # s <= CD <= sqrt(s^2 + 2 v^2).
    s, v = 0.03, DENSE.voxel_size
    ref = sample_meshes({1: _square()}, DENSE)
    pred = sample_meshes({1: _square(z=s)}, DENSE)
    m = point_metrics(downsample(pred, v), downsample(ref, v), thresholds=(0.02, 0.05))
    assert m["fscore@5cm"] == 1.0
    assert m["fscore@2cm"] == 0.0
    assert s - 1e-9 <= m["chamfer"] <= np.sqrt(s**2 + 2 * v**2)
    assert m["normal_consistency"] == pytest.approx(1.0)


def test_box_shifted_3cm_sideways():
    # A 1 m cube shifted 3 cm along x: the four faces parallel to x slide in their own planes (distance
    # ~0), the two x faces are 3 cm off. Every point is within 3 cm + the sampling gap (< 2 cm at this
    # density) of the other surface, so F@5 = 1; at 2 cm the x faces (1/3 of the area, less the bands
    # within 3 cm + 1 voxel of their edges, at most 4 * 0.05 of a face) fail: F@2 in [2/3 - 0.05, 2/3 + 1/15 + 0.05].
    cube = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    moved = cube.copy()
    moved.apply_translation([0.03, 0, 0])
    cfg = GeometryConfig(samples_per_m2=50000.0, thresholds=(0.02, 0.05))
    m = compare(sample_meshes({1: moved}, cfg), sample_meshes({1: cube}, cfg), cfg)
    assert m["fscore@5cm"] == 1.0
    assert 2 / 3 - 0.05 <= m["fscore@2cm"] <= 2 / 3 + 1 / 15 + 0.05
    # x faces: between s and sqrt(s^2 + 2 v^2) (less their edge bands); sliding faces: between 0 and the
    # covering radius sqrt(2) v of the other face's voxel means
    s, v = 0.03, cfg.voxel_size
    assert (1 / 3) * 0.8 * s <= m["chamfer"] <= (1 / 3) * np.sqrt(s**2 + 2 * v**2) + (2 / 3) * np.sqrt(2) * v
    assert m["centre_offset"] == pytest.approx(0.03, abs=0.005)


def test_normal_consistency_is_the_cosine_of_a_tilt():
    ref = sample_meshes({1: _square()}, DENSE)
    pred = sample_meshes({1: _square(tilt_deg=30.0)}, DENSE)
    m = compare(pred, ref, DENSE)
    assert m["normal_consistency"] == pytest.approx(np.cos(np.radians(30.0)), abs=1e-6)


def test_distances_match_open3d():
    rng = np.random.default_rng(0)
    a = PointSet(rng.uniform(0, 1, (3000, 3)))
    b = PointSet(rng.uniform(0, 1, (2000, 3)) + 0.01)
    m = point_metrics(a, b)
    pa = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(a.points))
    pb = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(b.points))
    acc = np.asarray(pa.compute_point_cloud_distance(pb)).mean()
    comp = np.asarray(pb.compute_point_cloud_distance(pa)).mean()
    assert m["accuracy"] == pytest.approx(acc, rel=1e-9)
    assert m["completion"] == pytest.approx(comp, rel=1e-9)
    assert m["chamfer"] == pytest.approx((acc + comp) / 2, rel=1e-9)
    assert m["normal_consistency"] is None


def test_downsample_matches_open3d_and_keeps_majority_labels():
    rng = np.random.default_rng(1)
    pts = rng.uniform(0, 0.5, (20000, 3))
    labels = np.where(pts[:, 0] < 0.25, 3, 7)
    down = downsample(PointSet(pts, None, labels), 0.02)
    ref = np.asarray(o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts)).voxel_down_sample(0.02).points)
    assert len(down) == len(ref)
    np.testing.assert_allclose(down.points[np.lexsort(down.points.T)], ref[np.lexsort(ref.T)], atol=1e-12)
    far = np.abs(down.points[:, 0] - 0.25) > 0.03
    assert np.all(down.labels[far] == np.where(down.points[far, 0] < 0.25, 3, 7))


def test_empty_sets_give_none():
    m = point_metrics(PointSet(np.zeros((0, 3))), PointSet(np.ones((5, 3))))
    assert m["chamfer"] is None and m["fscore@5cm"] is None and m["points_ref"] == 5


def _cameras_around(centre, radius: float, height: float, n: int) -> list[Camera]:
    K = np.array([[160.0, 0, 80], [0, 160.0, 60], [0, 0, 1]])
    out = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        eye = np.asarray(centre) + [radius * np.cos(a), radius * np.sin(a), height]
        out.append(Camera(K, look_at(eye, centre), 160, 120))
    return out


def test_refused_surface_leaves_out_what_no_camera_sees():
    # A box standing on the floor, seen from above-around: its bottom face is never seen, so the re-fused
    # points (unlike the sampled ones) have none on it; and identical scenes re-fuse to the same points.
    box = trimesh.creation.box(extents=[0.6, 0.6, 0.6])
    box.apply_translation([0, 0, 0.3])
    cams = _cameras_around([0, 0, 0.3], 2.0, 1.0, 12)
    cfg = GeometryConfig(fuse_scale=1.0)
    fused = refuse({1: box}, cams, cfg)
    assert len(fused) > 100 and set(np.unique(fused.labels)) == {1}
    bottom = (np.abs(fused.points[:, 2]) < 0.01) & (np.abs(fused.points[:, :2]).max(1) < 0.25)
    assert not bottom.any()
    sampled = sample_meshes({1: box}, cfg)
    assert ((np.abs(sampled.points[:, 2]) < 0.01) & (np.abs(sampled.points[:, :2]).max(1) < 0.25)).any()
    again = compare(fused, refuse({1: box}, cams, cfg), cfg)
    assert again["chamfer"] == pytest.approx(0.0, abs=1e-9) and again["fscore@5cm"] == 1.0
    # against the sampled box, the re-fused one is accurate (its points lie on the box) but incomplete
    m = compare(fused, sampled, cfg)
    assert m["accuracy"] < 0.01
    assert m["recall@5cm"] < 0.95


def test_voxel_sums_average_per_origin_anchored_voxel_whatever_the_chunks():
    # Three points in voxel (0, 0, 0) of a 0.1 m grid, two in voxel (-1, 0, 0): means, renormalised normals
    # and the majority label (the smaller label on a tie), the same from one chunk or point by point.
    from rescene_core.evaluation.geometry import VoxelSums

    pts = np.array([[0.01, 0.02, 0.03], [0.05, 0.06, 0.07], [0.09, 0.01, 0.02], [-0.01, 0.0, 0.0], [-0.05, 0.0, 0.0]])
    normals = np.array([[0.0, 0, 1], [0, 0, 1], [0, 1, 0], [1, 0, 0], [1, 0, 0]])
    labels = np.array([4, 7, 7, 9, 2])
    whole = VoxelSums(0.1)
    whole.add(PointSet(pts, normals, labels))
    single = VoxelSums(0.1)
    for k in range(len(pts)):
        single.add(PointSet(pts[k : k + 1], normals[k : k + 1], labels[k : k + 1]))
    for fused in (whole.result(), single.result()):
        assert len(fused) == 2
        np.testing.assert_allclose(fused.points, [pts[3:].mean(0), pts[:3].mean(0)], atol=1e-12)
        np.testing.assert_allclose(fused.normals, [[1, 0, 0], np.array([0, 1, 2]) / np.sqrt(5)], atol=1e-12)
        assert fused.labels.tolist() == [2, 7]
    assert len(VoxelSums(0.1).result()) == 0
    with pytest.raises(ValueError, match="fuse_voxel"):
        VoxelSums(0.0)
    with pytest.raises(ValueError, match="depth units"):
        VoxelSums(0.02).add(PointSet(np.array([[1e5, 0.0, 0.0]])))


def test_fusion_in_chunks_is_the_downsample_of_all_points(monkeypatch):
    # The fusion folds its points into voxel sums every FUSE_CHUNK_POINTS points (bounded memory on long
    # captures) on downsample's grid: chunks of a few hundred points give downsample(every point) exactly.
    import rescene_core.evaluation.geometry as geometry

    box = trimesh.creation.box(extents=[0.6, 0.6, 0.6])
    box.apply_translation([0, 0, 0.3])
    meshes = {1: box, 2: _square(z=0.0)}
    cams = _cameras_around([0, 0, 0.3], 2.0, 1.0, 6)
    cfg = GeometryConfig(fuse_scale=0.5)
    every = PointSet.concatenate(
        [geometry.backproject(d, c, labels=lab) for d, c, lab in geometry.rendered_depths(meshes, cams, cfg)]
    )
    expected = downsample(every, cfg.fuse_voxel)
    monkeypatch.setattr(geometry, "FUSE_CHUNK_POINTS", 300)
    chunked = refuse(meshes, cams, cfg)
    assert len(every) > 10 * 300 and len(chunked) == len(expected)
    np.testing.assert_allclose(chunked.points, expected.points, atol=1e-12)
    np.testing.assert_allclose(chunked.normals, expected.normals, atol=1e-9)
    np.testing.assert_array_equal(chunked.labels, expected.labels)
    assert set(np.unique(expected.labels)) == {1, 2}
