"""The egocentric preset: a head-mounted walk over part of a kitchen, raised supports with children in the
ground truth, and labels with "/", spaces and accents that survive the capture's round trips."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import MultiPoint, Point

from flows.cli import build_parser
from rescene_core.capture import check_capture, open_capture
from rescene_core.capture.ground_truth import read_ground_truth
from rescene_core.capture.synth import get_preset, make_scene, write_scene
from rescene_core.capture.synth.presets import HEAD_FIELDS
from rescene_core.capture.synth.verify import interpenetrations, outside_room, relation_problems
from rescene_core.records import Relation, Root

SMALL = dict(frames=24, width=240, height=180)
"""Fewer and smaller frames than the preset's 72 at 480x360: the same room and walking path, sampled coarser."""


@pytest.fixture(scope="module")
def ego():
    return make_scene("egocentric", seed=0, **SMALL)


def _pitch_roll_deg(world_from_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pitch of the optical axis below the horizon and roll of the image x axis out of the horizontal (deg)."""
    rot = world_from_cam[:, :3, :3]
    pitch = np.degrees(np.arcsin(-rot[:, 2, 2]))
    level_x = np.cross(rot[:, :, 2], [0.0, 0.0, 1.0])
    level_x /= np.linalg.norm(level_x, axis=1, keepdims=True)
    roll = np.degrees(np.arccos(np.clip((level_x * rot[:, :, 0]).sum(1), -1.0, 1.0)))
    return pitch, roll


def test_the_preset_is_a_head_mounted_walk(ego):
    cfg = get_preset("egocentric")
    assert (cfg.frames, cfg.width, cfg.height, cfg.camera) == (72, 480, 360, "head")
    assert cfg.head_pitch_deg == (20.0, 60.0) and cfg.walk_height == (1.5, 1.8) and cfg.head_roll_deg == 15.0
    poses = ego.plan.world_from_cam
    assert ego.arrays.rgb.shape == (24, 180, 240, 3) and set(ego.plan.kinds) == {"head"}
    assert np.all((poses[:, 2, 3] >= 1.5) & (poses[:, 2, 3] <= 1.8))
    pitch, roll = _pitch_roll_deg(poses)
    assert pitch.min() >= 20.0 - 1e-6 and pitch.max() <= 60.0 + 1e-6
    assert pitch.max() - pitch.min() > 10.0  # the head looks near and far, not at one fixed angle
    assert roll.max() <= 15.0 + 1e-6 and roll.max() > 3.0
    # every view turns at most 45 deg from facing the kitchen wall
    _, _, into_room = ego.layout.kitchen_axes()
    ahead = poses[:, :2, 2] / np.linalg.norm(poses[:, :2, 2], axis=1, keepdims=True)
    assert np.degrees(np.arccos(np.clip(ahead @ -into_room, -1.0, 1.0))).max() <= 45.0 + 1e-6


def test_the_walk_sees_only_part_of_the_room(ego):
    gt, a = ego.gt, ego.arrays
    seen_walls = {s.wall_id for s in gt.structure if s.kind == "wall"}
    kitchen = ego.layout.kitchen_wall
    behind = [w.id for w in gt.shell.walls if np.dot(w.plane.normal, kitchen.plane.normal) < -0.99]
    assert behind and behind[0] not in seen_walls and kitchen.id in seen_walls

    floor = next(int(i.id) for i in a.instances if i.label == "floor")
    k = list(a.point_ids).index(floor)
    floor_points = a.points[a.point_offsets[k] : a.point_offsets[k + 1]]
    room = gt.shell.polygon()
    x0, y0, x1, y1 = room.bounds
    cell = 0.2
    cells = {
        (i, j)
        for i, x in enumerate(np.arange(x0 + cell / 2, x1, cell))
        for j, y in enumerate(np.arange(y0 + cell / 2, y1, cell))
        if room.contains(Point(x, y))
    }
    seen = {(int((p[0] - x0) // cell), int((p[1] - y0) // cell)) for p in floor_points} & cells
    assert 0.05 < len(seen) / len(cells) < 0.6  # the floor is seen in patches

    # nothing at floor height under the island's and the worktops' bodies (their outlines less the overhangs
    # and toe kicks); floor-labelled points higher up are other surfaces' pixels the mask noise gave the floor
    floor_points = floor_points[floor_points[:, 2] < 0.05]
    for o in gt.objects:
        if o.label in ("kitchen island", "kitchen counter"):
            outline = MultiPoint(o.world_vertices()[:, :2]).convex_hull
            body = outline.buffer(-0.35 if o.label == "kitchen island" else -0.12)
            assert not any(body.contains(Point(p[0], p[1])) for p in floor_points), o.label

    # some object is never seen whole: the image border cuts it in every frame it is in
    ids = ego.object_id_frames
    cut = []
    for o in gt.objects:
        mask = ids == o.object_id
        in_frame = mask.any(axis=(1, 2))
        border = mask[:, 0].any(1) | mask[:, -1].any(1) | mask[:, :, 0].any(1) | mask[:, :, -1].any(1)
        if in_frame.any() and border[in_frame].all():
            cut.append(o.label)
    assert cut


@pytest.mark.parametrize("seed", [0, 1])
def test_raised_supports_carry_children_in_the_ground_truth(seed):
    scene = make_scene("egocentric", seed, frames=2, width=32, height=24)
    gt = scene.gt
    assert relation_problems(gt, tolerance=0.01) == []
    assert interpenetrations(gt, max_volume=1e-6) == []
    assert outside_room(gt) == []
    label = {o.object_id: o.label for o in gt.objects}
    rel = {r.child: r for r in gt.relations}
    children: dict[int, list[str]] = {}
    for r in gt.relations:
        if r.relation == Relation.RESTS_ON and isinstance(r.parent, int):
            children.setdefault(r.parent, []).append(label[r.child])

    island = [o for o in gt.objects if o.label == "kitchen island"]
    assert len(island) == 1 and rel[island[0].object_id].parent == Root.FLOOR
    top = float(island[0].world_vertices()[:, 2].max())
    assert 0.85 <= top <= 0.95
    assert len(children[island[0].object_id]) >= 3
    counters = [o.object_id for o in gt.objects if o.label == "kitchen counter"]
    assert len(counters) >= 2 and any(children.get(c) for c in counters)
    cups = [r for r in gt.relations if label[r.child] == "coffee cup"]
    assert cups and all(label.get(r.parent) in ("kitchen island", "kitchen counter", "tray") for r in cups)
    tray = next(o.object_id for o in gt.objects if o.label == "tray")
    assert rel[tray].parent == island[0].object_id and children.get(tray)  # two levels: cup on tray on island

    kitchen_wall = scene.layout.kitchen_wall.id
    worktop = max(float(gt.object(c).world_vertices()[:, 2].max()) for c in counters)
    wall_cabinets = [o for o in gt.objects if o.label == "cabinet/wardrobe part"]
    assert wall_cabinets
    for o in wall_cabinets:
        r = rel[o.object_id]
        assert (r.relation, r.parent, r.wall_id) == (Relation.MOUNTS_ON, Root.WALL, kitchen_wall)
        assert float(o.world_vertices()[:, 2].min()) > worktop + 0.4
    sizes = [float((o.vertices.max(0) - o.vertices.min(0)).max()) for o in gt.objects]
    assert sum(s < 0.1 for s in sizes) >= 2


def test_same_seed_same_egocentric_capture():
    a = make_scene("egocentric", 3, frames=3, width=48, height=36)
    b = make_scene("egocentric", 3, frames=3, width=48, height=36)
    assert a.arrays.world_from_cam.tobytes() == b.arrays.world_from_cam.tobytes()
    assert a.arrays.rgb.tobytes() == b.arrays.rgb.tobytes() and a.arrays.instances == b.arrays.instances


def test_labels_with_slash_and_accents_survive_write_and_read(ego, tmp_path):
    from rescene_core.capture.importers import ImportOptions, import_capture
    from rescene_core.capture.importers.layouts import write_panoptic

    labels = [i.label for i in ego.arrays.instances]
    assert "cabinet/wardrobe part" in labels and "crème jar" in labels and "cutting board" in labels
    path = write_scene(tmp_path / "ego.zarr", ego)["capture"]
    assert [p for p in check_capture(path) if p.severity == "error"] == []
    capture = open_capture(path)
    assert [i.label for i in capture.instances] == labels
    gt = read_ground_truth(capture)
    assert gt is not None and [o.label for o in gt.objects] == [o.label for o in ego.gt.objects]
    assert gt.relations == ego.gt.relations

    # through the importers' panoptic layout (labels.json) and back
    src = write_panoptic(ego.arrays, tmp_path / "src")
    report = import_capture("panoptic", src, tmp_path / "back.zarr", ImportOptions(align="none"))
    assert report["frames"]["kept"] == 24
    back = {int(i.id): i.label for i in open_capture(tmp_path / "back.zarr").instances}
    # the importer drops instances too small for its own fusion at this resolution; the rest keep their labels
    assert back == {int(i.id): i.label for i in ego.arrays.instances if int(i.id) in back}
    assert {"cabinet/wardrobe part", "crème jar"} <= set(back.values())


def test_the_cli_and_the_benches_take_the_preset():
    parser = build_parser()
    assert parser.parse_args(["synth", "k.zarr", "--preset", "egocentric"]).preset == "egocentric"
    assert parser.parse_args(["bench", "assembly", "--preset", "egocentric"]).preset == "egocentric"
    from rescene_core.bench.assembly import EXTRA_PRESETS, PRESETS, ground_truth_layout

    assert "egocentric" in EXTRA_PRESETS and "egocentric" not in PRESETS  # not part of --preset all
    # the assembly and sim benches build the layout without rendering: it is make_scene's ground truth
    objects, graph, _, source = ground_truth_layout("egocentric", 1)
    gt = make_scene("egocentric", 1, frames=2, width=32, height=24).gt
    assert source.startswith("synth layout") and len(objects) == len(gt.objects)
    for o in gt.objects:
        assert np.array_equal(objects[o.object_id].world_from_asset, o.world_from_object)
    assert {(int(e.child), e.relation) for e in graph.edges} == {(r.child, r.relation) for r in gt.relations}


def test_only_the_head_walk_records_its_settings():
    standard = get_preset("standard")
    assert standard.settings() == {k: v for k, v in standard.model_dump(mode="json").items() if k not in HEAD_FIELDS}
    ego = get_preset("egocentric").settings()
    assert ego["camera"] == "head" and ego["head_pitch_deg"] == [20.0, 60.0]
