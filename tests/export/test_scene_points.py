"""scene/points.zarr: surface samples of the placed objects, read back with zarr's own reader."""

import numpy as np
import pytest
import trimesh
import zarr

from rescene_core.export import ExportConfig, ExportObject, read_scene_points, write_scene_points
from rescene_core.geometry import sim3


def _objects():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    placed = sim3.sim3_from_parts(0.5, np.eye(3), np.array([2.0, 1.0, 0.25]))
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
    return [
        ExportObject(7, "cabinet", box.vertices, box.faces, placed),
        ExportObject(3, "lamp", sphere.vertices, sphere.faces, np.eye(4)),
    ]


def test_points_lie_on_the_placed_surfaces(tmp_path):
    objects = _objects()
    config = ExportConfig(points_per_m2=2000, min_points_per_object=50, max_points_per_object=5000)
    path = write_scene_points(tmp_path / "points.zarr", objects, config)
    root = zarr.open_group(str(path), mode="r")
    assert root.attrs["format"] == "rescene-scene-points"
    assert root["ids"][...].tolist() == [3, 7]
    offsets = root["offsets"][...]
    assert offsets[0] == 0 and offsets[-1] == root["points"].shape[0] == root["normals"].shape[0]
    clouds = read_scene_points(path)
    # the 0.5-scaled unit box at (2, 1, 0.25): area 1.5 m^2 -> 3000 samples, all on its faces
    cab = clouds[7]
    assert len(cab) == 3000
    local = np.abs(cab - [2.0, 1.0, 0.25])
    assert np.allclose(local.max(axis=1), 0.25, atol=1e-5)
    assert np.allclose(np.linalg.norm(root["normals"][...], axis=1), 1.0, atol=1e-5)
    # the lamp: clamped by the per-object bounds, on the sphere
    lamp = clouds[3]
    assert 50 <= len(lamp) <= 5000
    assert np.allclose(np.linalg.norm(lamp, axis=1), 0.5, atol=0.02)


def test_same_layout_same_file_and_atomic(tmp_path):
    objects = _objects()
    a = read_scene_points(write_scene_points(tmp_path / "a.zarr", objects, ExportConfig()))
    b = read_scene_points(write_scene_points(tmp_path / "b.zarr", objects, ExportConfig()))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.zarr", "b.zarr"]


def test_reader_rejects_other_groups(tmp_path):
    zarr.open_group(str(tmp_path / "x.zarr"), mode="w").attrs["format"] = "something-else"
    with pytest.raises(ValueError, match="not a rescene-scene-points"):
        read_scene_points(tmp_path / "x.zarr")
