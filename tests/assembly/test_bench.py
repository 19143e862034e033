"""The assembly benchmark's pieces on the hand-built bedroom (the suite itself runs on synthetic scenes)."""

from __future__ import annotations

from rescene_core.bench.assembly import METRICS, perturb, run_stages, scaling, table
from tests.assembly.helpers import scene


def test_stages_improve_a_perturbed_scene():
    objects, graph, shell = scene()
    start, modes = perturb(objects, graph, shell, seed=3)
    assert set(modes) == {int(i) for i in objects}
    stages = run_stages(objects, start, graph, shell)
    assert list(stages) == ["none", "relations", "repair", "full"]
    full = stages["full"]
    assert full["oob_rate"] == 0.0 and full["collision_pairs"] == 0
    assert full["floor_contact_pass"] == 1.0 and full["support_contact_pass"] == 1.0
    assert full["pose_err_median"] <= stages["none"]["pose_err_median"] + 1e-9


def test_scaling_and_table_render():
    s = scaling(repeats=1)
    assert s["20"] > 0 and s["80"] > 0
    result = {
        "summary": {
            "development": {
                "seeds": [0],
                "x": {st: {k: 0.0 for k in METRICS} for st in ("none", "relations", "repair", "full")},
            }
        },
        "scaling": s,
        "not_run": {"fused_graph": "why"},
        "seeds": [0],
    }
    assert "scaling" in table(result)


def test_registration_keys_name_preset_shapes_and_graph():
    from rescene_core.bench.assembly import registration_key

    assert registration_key("standard", "fused") == "registration"
    assert registration_key("cluttered", "gt", "exact") == "registration_cluttered_exact_shapes_gt_graph"


def test_exact_shapes_are_registered_once_and_cached(tmp_path, monkeypatch):
    import numpy as np

    import rescene_core.registration as registration
    from rescene_core.bench.assembly import exact_shape_objects
    from rescene_core.capture import open_capture
    from rescene_core.capture.ground_truth import read_ground_truth
    from rescene_core.capture.synth import write_synth

    cap = open_capture(write_synth(tmp_path / "tiny.zarr", preset="tiny", seed=0), validate=False)
    gt = read_ground_truth(cap)
    instances = set(gt.object_of_instance())
    cache = tmp_path / "poses.json"
    objects = exact_shape_objects(cap, gt, instances, cache)
    assert cache.exists() and objects and all(o.exact_shape for o in objects.values())
    errors = []
    for i, obj in objects.items():
        true = gt.world_mesh(gt.object_of_instance()[int(i)]).vertices
        placed = obj.world_vertices()
        errors.append(np.linalg.norm(0.5 * (true.min(0) + true.max(0)) - 0.5 * (placed.min(0) + placed.max(0))))
    # the ground-truth mesh registered to its own instance's points: near the object (the tiny preset's
    # 160 x 120 frames give coarse points, so centimetres, not millimetres); unregistered it sits at the origin
    assert max(errors) < 0.15

    def no_registration(*args, **kwargs):
        raise AssertionError("cached poses must not be registered again")

    monkeypatch.setattr(registration, "register", no_registration)
    again = exact_shape_objects(cap, gt, instances, cache)
    assert {i: o.world_from_asset.tolist() for i, o in again.items()} == {
        i: o.world_from_asset.tolist() for i, o in objects.items()
    }


def test_registration_stages_report_how_far_attachment_moved_each_object():
    from dataclasses import replace

    import numpy as np

    from rescene_core.assembly.scenes import box_object, placed, rect_room
    from rescene_core.bench.assembly import _registration_stages
    from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph

    # a crate registered 0.1 m above the floor it rests on, its points where the crate is
    crate = box_object(1, "crate", (0.4, 0.4, 0.3), placed(2.0, 2.5, 0.1), exact_shape=False)
    rng = np.random.default_rng(0)
    crate = replace(
        crate, points=np.c_[rng.uniform(1.8, 2.2, 400), rng.uniform(2.3, 2.7, 400), rng.uniform(0, 0.3, 400)]
    )
    graph = SceneGraph((Edge(InstanceId(1), Relation.RESTS_ON, Root.FLOOR, 1.0),))
    stages = _registration_stages(
        {InstanceId(1): crate}, graph, rect_room(), {InstanceId(1): np.array([2.0, 2.5, 0.15])}
    )
    assert stages["none"]["moved_max_m"] == 0.0 and stages["none"]["moved_over_bound"] == 0
    assert abs(stages["full"]["moved_max_m"] - 0.1) < 0.002  # dropped onto the floor, nothing else
    assert stages["full"]["moved_over_bound"] == 0
    assert stages["full"]["pose_err_median"] < 0.002
