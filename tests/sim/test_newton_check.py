"""The physics check in Newton: the USD loads through Newton's UsdPhysics importer, the same verdicts as
MuJoCo on a resting, a falling and a sunk box, and the comparison names what the two files declare."""

from __future__ import annotations

import json

import pytest

from rescene_core.export import ExportConfig, export_scene
from rescene_core.records import Edge, InstanceId, Relation, Root, SceneGraph
from rescene_core.sim import SimcheckConfig, simcheck_run
from rescene_core.sim.newton_check import NewtonUnavailable, _mujoco_facts, compare, newton_simcheck_run
from tests.fixtures import ONE_WALL_SHELL, export_box

pytest.importorskip("newton", reason="the `newton` extra is not installed (make setup installs it)")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    objects = [
        export_box(1, "cabinet", [0.0, 0.0, 0.2005]),  # resting: stable
        export_box(2, "cabinet", [1.0, 0.0, 0.5]),  # floating 0.3 m: falls
        export_box(3, "cabinet", [-1.0, 0.5, 0.19]),  # sunk 1 cm into the floor
        export_box(4, "picture", [0.5, -1.98, 1.5], (0.5, 0.04, 0.4)),  # on the wall: mounted, fixed
    ]
    graph = SceneGraph(
        tuple(Edge(InstanceId(i), Relation.RESTS_ON, Root.FLOOR) for i in (1, 2, 3))
        + (Edge(InstanceId(4), Relation.MOUNTS_ON, Root.WALL),)
    )
    export_scene(run / "scene", objects, ONE_WALL_SHELL, graph, [], ExportConfig(decomposition_cache=str(run / "c")))
    return run


@pytest.fixture(scope="module")
def checks(run_dir):
    """Both engines' checks of the scene, 1 s each: (MuJoCo's result, Newton's record)."""
    config = SimcheckConfig(seconds=1.0)
    return simcheck_run(run_dir, config), newton_simcheck_run(run_dir, config)


def test_newton_reads_the_usd_and_agrees_with_mujoco_on_clear_cases(run_dir, checks):
    mujoco, record = checks
    by_node = {o["node"]: o for o in record["objects"]}
    assert {n: o["kind"] for n, o in by_node.items()} == {o.node: o.kind for o in mujoco.objects}
    assert by_node["obj_4_picture"]["kind"] == "fixed"  # a static collider: the USD declares no rigid body
    assert by_node["obj_1_cabinet"]["stable"] and by_node["obj_1_cabinet"]["penetration_t0"] < 1e-3
    assert not by_node["obj_2_cabinet"]["stable"]
    assert by_node["obj_2_cabinet"]["translation"] == pytest.approx(0.3, abs=0.03)
    assert by_node["obj_3_cabinet"]["penetration_t0"] == pytest.approx(0.01, abs=3e-3)
    s = record["summary"]
    # the sunk box: XPBD's 8 iterations project it out of the floor within one 1 ms step, and the push
    # becomes velocity: it leaves the room
    assert (s["free"], s["fixed"], s["fell_through"], s["escaped"]) == (3, 1, 0, 1)
    assert record["engine"] == "newton" and record["config"]["timestep"] == pytest.approx(0.001)
    # the sunk box: MuJoCo's soft contact lifts it 1 cm; XPBD projects it out and it jumps: named, with why
    (d,) = record["disagreements"]
    assert d["node"] == "obj_3_cabinet" and d["stable_mujoco"] and not d["stable_newton"]
    assert any(r.startswith("penetrating 10") for r in d["reasons"])
    on_disk = json.loads((run_dir / "sim/simcheck-newton.json").read_text())
    assert on_disk["summary"] == s
    # the model facts Newton read match what the export declared: pieces per object and masses
    report = json.loads((run_dir / "scene/export_report.json").read_text())
    pieces = {o["node"]: o["collision_pieces"] for o in report["objects"]}
    assert record["config"]["pieces"] == pieces
    assert record["config"]["mass"]["obj_4_picture"] is None
    # every collider carries the category's friction (MJCF geom friction), not Newton's default of 1.0
    _, _, mujoco_friction = _mujoco_facts(run_dir / "scene/mjcf/scene.xml")
    assert record["config"]["friction"] == mujoco_friction and 1.0 not in mujoco_friction.values()


def test_a_declared_difference_is_named(run_dir, checks):
    mujoco, newton = checks
    flipped = json.loads(json.dumps(newton))
    for o in flipped["objects"]:
        if o["node"] == "obj_1_cabinet":
            o["stable"] = False
    flipped["config"]["mass"]["obj_1_cabinet"] *= 2
    flipped["config"]["pieces"]["obj_1_cabinet"] += 1
    flipped["config"]["friction"]["obj_1_cabinet"] = 1.0
    d = {d["node"]: d for d in compare(mujoco.to_json(), flipped, run_dir / "scene/mjcf/scene.xml")}["obj_1_cabinet"]
    assert d["node"] == "obj_1_cabinet" and d["stable_mujoco"] and not d["stable_newton"]
    assert any(r.startswith("mass:") for r in d["reasons"]) and any(
        r.startswith("collision pieces") for r in d["reasons"]
    )


def test_without_newton_the_error_says_how_to_install(monkeypatch, run_dir):
    import builtins

    real_import = builtins.__import__

    def no_newton(name, *args, **kwargs):
        if name == "newton":
            raise ImportError("No module named 'newton'", name="newton")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_newton)
    with pytest.raises(NewtonUnavailable, match=r"rescene\[newton\]"):
        newton_simcheck_run(run_dir)


def test_missing_usd_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="export the scene first"):
        newton_simcheck_run(tmp_path)


def test_the_flow_stage_runs_newton_when_asked_and_the_report_shows_where_the_engines_differ(
    run_dir, tmp_path, monkeypatch
):
    """``sim.newton``: the physics stage writes sim/simcheck-newton.json beside MuJoCo's check, and the
    evaluation report puts both engines side by side with the disagreeing object and its reasons. Without
    the extra, the stage keeps MuJoCo's result and the report says why Newton did not run."""
    import shutil

    from rescene_core.evaluation.report_html import _physics_newton
    from rescene_core.stages import simcheck as stage

    run = tmp_path / "run"
    shutil.copytree(run_dir / "scene", run / "scene")
    stage.run(str(run), None, SimcheckConfig(seconds=1.0, newton=True))
    record = json.loads((run / "sim/simcheck-newton.json").read_text())
    assert [d["node"] for d in record["disagreements"]] == ["obj_3_cabinet"]
    page = _physics_newton({"physics": json.loads((run / "sim/simcheck.json").read_text()), "physics_newton": record})
    assert "Newton (scene/scene.usda)" in page and "MuJoCo (scene/mjcf/scene.xml)" in page
    assert "Where the engines disagree (1)" in page and "obj_3_cabinet" in page and "penetrating 10" in page

    def unavailable(*args, **kwargs):
        raise NewtonUnavailable("the Newton engine needs the `newton` extra")

    monkeypatch.setattr("rescene_core.sim.newton_check.newton_simcheck_run", unavailable)
    stage.run(str(run), None, SimcheckConfig(seconds=1.0, newton=True))
    assert (run / "sim/simcheck.json").exists() and not (run / "sim/simcheck-newton.json").exists()
    page = _physics_newton({"not_computed": {"physics_newton": "no sim/simcheck-newton.json"}})
    assert "Newton check: not run" in page
