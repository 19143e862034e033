"""Synthetic captures: validity, determinism, ground truth, and the error dials (tiny preset)."""

from __future__ import annotations

import numpy as np
import pytest

from flows.cli import main
from rescene_core.capture import check_capture, open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.capture.synth import make_scene, write_synth


@pytest.fixture(scope="module")
def tiny():
    return make_scene("tiny", seed=0)


def test_tiny_capture_is_valid_and_has_ground_truth(tmp_path):
    path = write_synth(tmp_path / "tiny.zarr", "tiny", seed=1)
    problems = check_capture(path)
    assert [p for p in problems if p.severity == "error"] == []
    capture = open_capture(path)
    assert capture.num_frames == 12 and capture.image_size == (160, 120)
    gt = read_ground_truth(capture)
    assert gt is not None and 1 <= len(gt.objects) <= 6
    labels = {i.label for i in capture.instances if i.structural}
    assert {"floor", "wall"} <= labels
    assert gt.graph_by_instance().check() == []


def test_write_refuses_existing_path(tmp_path):
    write_synth(tmp_path / "a.zarr", "tiny", seed=0)
    with pytest.raises(FileExistsError):
        write_synth(tmp_path / "a.zarr", "tiny", seed=0)


def test_unknown_preset_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown synth preset"):
        make_scene("huge", 0)


def test_synth_cli_writes_the_capture_and_prints_what_it_made(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "c.zarr"), "--preset", "tiny", "--seed", "2"]) == 0
    out = capsys.readouterr().out
    assert "wrote" in out and "objects" in out
    assert len(open_capture(tmp_path / "c.zarr").object_instances) >= 1


def test_same_seed_same_arrays(tiny):
    again = make_scene("tiny", seed=0)
    a, b = tiny.arrays, again.arrays
    for name in ("rgb", "instance_masks", "depth", "K", "world_from_cam", "points", "colors", "point_ids"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), name
    assert a.instances == b.instances
    other = make_scene("tiny", seed=1)
    assert other.arrays.rgb.tobytes() != a.rgb.tobytes()


# ---- ground truth is physically true ------------------------------------------------------------------


@pytest.mark.parametrize("preset,seed", [("tiny", 0), ("tiny", 3), ("standard", 0), ("standard", 1), ("cluttered", 0)])
def test_relations_hold_and_nothing_interpenetrates(preset, seed):
    from rescene_core.capture.synth.verify import interpenetrations, outside_room, relation_problems

    # the layout does not depend on the camera settings: render two small frames only
    scene = make_scene(preset, seed, frames=2, width=32, height=24)
    gt = scene.gt
    assert relation_problems(gt, tolerance=0.01) == []
    assert interpenetrations(gt, max_volume=1e-6) == []
    assert outside_room(gt) == []
    kinds = {(r.relation.value, "object" if isinstance(r.parent, int) else r.parent.value) for r in gt.relations}
    assert ("rests-on", "floor") in kinds and ("rests-on", "object") in kinds and ("mounts-on", "wall") in kinds


def test_verify_catches_a_floating_object_and_an_overlap():
    from rescene_core.capture.ground_truth import GroundTruth, GtObject
    from rescene_core.capture.synth.verify import interpenetrations, relation_problems

    gt = make_scene("tiny", 0, frames=2, width=32, height=24).gt
    lifted = []
    for o in gt.objects:
        pose = o.world_from_object.copy()
        pose[2, 3] += 0.05
        lifted.append(GtObject(o.object_id, o.label, o.vertices, o.faces, pose, o.instance_ids))
    problems = relation_problems(GroundTruth(tuple(lifted), gt.relations, gt.shell), tolerance=0.01)
    floor_children = [r for r in gt.relations if r.parent == "floor"]
    assert len([p for p in problems if "rests on the floor" in p]) == len(floor_children)
    stacked = list(gt.objects)
    a, b = stacked[0], stacked[1]
    stacked[1] = GtObject(b.object_id, b.label, a.vertices, a.faces, a.world_from_object, b.instance_ids)
    assert interpenetrations(GroundTruth(tuple(stacked), gt.relations, gt.shell))


def test_standard_scene_has_the_categories_and_counts():
    scene = make_scene("standard", 2, frames=2, width=32, height=24)
    assert 20 <= len(scene.gt.objects) <= 25
    assert len({o.label for o in scene.gt.objects}) >= 12
    clutter = make_scene("cluttered", 1, frames=2, width=32, height=24)
    assert len(clutter.gt.objects) >= 40
    parent_of = {r.child: r.parent for r in clutter.gt.relations}
    # stacked: an object on an object that itself rests on an object (books on books on a shelf)
    assert any(isinstance(p, int) and isinstance(parent_of[p], int) for p in parent_of.values())


# ---- the error dials change what they say ------------------------------------------------------------

CLEAN = dict(
    mask_boundary_prob=0.0,
    drift_frame_prob=0.0,
    split_prob=0.0,
    miss_small_prob=0.0,
    wrong_label_prob=0.0,
    depth_noise_base=0.0,
    depth_noise_quadratic=0.0,
    depth_dropout=0.0,
)


def _mislabelled_pixels(scene) -> int:
    """Pixels whose instance shows an object other than the one actually seen there."""
    obj_of = scene.gt.object_of_instance()
    lut = np.zeros(max(int(i.id) for i in scene.arrays.instances) + 1, np.int32)
    for inst, obj in obj_of.items():
        lut[inst] = obj
    shown = lut[scene.arrays.instance_masks]
    truth = scene.object_id_frames
    return int(((shown > 0) & (truth > 0) & (shown != truth)).sum())


def _surface_distance(scene) -> float:
    """Median distance (m) of the object points to their ground-truth object surface."""
    import open3d as o3d

    obj_of = scene.gt.object_of_instance()
    dists = []
    for oid in sorted(set(obj_of.values())):
        mesh = scene.gt.world_mesh(oid)
        rc = o3d.t.geometry.RaycastingScene()
        rc.add_triangles(
            o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)), o3d.core.Tensor(np.asarray(mesh.faces, np.uint32))
        )
        for inst in [i for i, o in obj_of.items() if o == oid]:
            row = list(scene.arrays.point_ids).index(inst)
            a, b = scene.arrays.point_offsets[row], scene.arrays.point_offsets[row + 1]
            pts = scene.arrays.points[a:b]
            dists.append(rc.compute_distance(o3d.core.Tensor(pts)).numpy())
    return float(np.median(np.concatenate(dists)))


def test_clean_dials_give_exact_masks():
    scene = make_scene("tiny", 0, **CLEAN)
    assert _mislabelled_pixels(scene) == 0
    assert scene.events == []


def test_depth_noise_dial_moves_points_off_the_surface():
    quiet = _surface_distance(make_scene("tiny", 0, **CLEAN))
    noisy = _surface_distance(
        make_scene("tiny", 0, **{**CLEAN, "depth_noise_base": 0.01, "depth_noise_quadratic": 0.01})
    )
    assert quiet < 0.006
    assert noisy > 2 * quiet


def test_boundary_noise_dial_mislabels_pixels_near_edges():
    scene = make_scene("tiny", 0, **{**CLEAN, "mask_boundary_prob": 0.8})
    assert _mislabelled_pixels(scene) > 0


def test_drift_dial_makes_masks_cover_a_neighbour():
    scene = make_scene("tiny", 0, **{**CLEAN, "drift_frame_prob": 1.0})
    drifts = [e for e in scene.events if e["kind"] == "drift"]
    assert len(drifts) >= 3
    obj_of = scene.gt.object_of_instance()
    e = drifts[0]
    masks, truth = scene.arrays.instance_masks[e["frame"]], scene.object_id_frames[e["frame"]]
    covered = (masks == e["instance"]) & (truth == obj_of[e["onto"]])
    assert covered.sum() == e["pixels"] > 0


def test_split_dial_gives_an_object_two_instances():
    scene = make_scene("tiny", 0, **{**CLEAN, "split_prob": 1.0, "split_min_size": 0.5})
    split = [o for o in scene.gt.objects if len(o.instance_ids) == 2]
    assert split
    masks = scene.arrays.instance_masks
    for o in split:
        assert all((masks == i).any() for i in o.instance_ids)
        assert all(i in scene.arrays.point_ids for i in o.instance_ids)
        counts = [int((masks == i).sum()) for i in o.instance_ids]
        assert counts[0] > 0 and counts[1] > 0
    assert scene.gt.graph_by_instance().check() == []


def test_miss_dial_drops_small_objects():
    scene = make_scene("tiny", 0, **{**CLEAN, "miss_small_prob": 1.0})
    missed = [o for o in scene.gt.objects if o.instance_ids == ()]
    assert missed and all(max(o.vertices.max(0) - o.vertices.min(0)) < 0.3 for o in missed)
    for o in missed:
        assert not ((scene.object_id_frames == o.object_id) & (scene.arrays.instance_masks != 0)).any()


def test_wrong_label_dial_changes_instance_labels():
    scene = make_scene("tiny", 0, **{**CLEAN, "wrong_label_prob": 1.0})
    label_of = {int(i.id): i.label for i in scene.arrays.instances}
    wrong = [o for o in scene.gt.objects if o.instance_ids and label_of[o.instance_ids[0]] != o.label]
    assert len(wrong) == len([o for o in scene.gt.objects if o.instance_ids])


def test_object_ids_are_not_instance_ids_and_structure_is_labelled():
    scene = make_scene("tiny", 0)
    obj_of = scene.gt.object_of_instance()
    assert any(i != o for i, o in obj_of.items())
    labels = {int(i.id): (i.label, i.structural) for i in scene.arrays.instances}
    for s in scene.gt.structure:
        assert labels[s.instance_id] == (s.kind, True)
    walls = [s for s in scene.gt.structure if s.kind == "wall"]
    assert {s.wall_id for s in walls} <= {w.id for w in scene.gt.shell.walls}
