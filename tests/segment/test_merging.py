"""Region merging rules on hand-made point sets: what rests on a top stays apart from it, slender uprights
under a broader region join it, and a hanging region faces the room as its wall does."""

from __future__ import annotations

import numpy as np

from rescene_core.segment.geometric import ScanPoints, SegmentConfig
from rescene_core.segment.geometric.joins import _attach_legs, _join_bedding, _join_stems
from rescene_core.segment.geometric.structure import _faces_wall
from rescene_core.segment.geometric.support import _rests_on, _under_board
from rescene_core.segment.superpoints import edge_weights, point_graph, superpoint_graph

STEP = 0.025
CFG = SegmentConfig()
MIN_TOP = CFG.support_min_height  # the least height of a top that carries bodies of its own
WALL = [{"kind": "floor", "id": 1}, {"kind": "wall", "id": 2, "normal": [0.0, 1.0, 0.0], "offset": 0.0}]  # y = 0


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> np.ndarray:
    """Points [n, 3] filling an axis-aligned box on a STEP grid (m)."""
    axes = [np.arange(a, b + 1e-9, STEP) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def test_a_body_on_a_shelf_rests_on_it_and_a_board_or_a_mattress_does_not():
    # a bookcase 1 m wide, 0.4 m deep; the shelf top at z = 0.7 is seen around a book stack standing on it
    shelf = _box((0.0, 0.0, 0.7), (1.0, 0.4, 0.7))
    big_lo, big_hi = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.4, 1.8])
    stack = np.array([0.3, 0.1, 0.7]), np.array([0.5, 0.3, 0.85])
    under = np.all((shelf[:, :2] >= stack[0][:2]) & (shelf[:, :2] <= stack[1][:2]), axis=1)
    tops = shelf[~under]  # the shelf under the stack is hidden
    assert _rests_on(tops, *stack, big_lo, big_hi, MIN_TOP, CFG)
    # a shelf board (2 cm thick) lies at the same height but is part of the frame
    assert not _rests_on(tops, np.array([0.0, 0.0, 0.7]), np.array([0.6, 0.4, 0.72]), big_lo, big_hi, MIN_TOP, CFG)
    # a body as wide as the larger region (a mattress in its bed's frame) stays with it
    assert not _rests_on(tops, np.array([0.02, 0.02, 0.7]), np.array([0.98, 0.3, 0.9]), big_lo, big_hi, MIN_TOP, CFG)
    # nothing under its footprint at its lowest height: it does not stand on this top
    assert not _rests_on(tops, np.array([0.3, 0.1, 1.1]), np.array([0.5, 0.3, 1.3]), big_lo, big_hi, MIN_TOP, CFG)


def _scan(parts: list[np.ndarray]) -> tuple[ScanPoints, np.ndarray]:
    """ScanPoints whose superpoints are the given parts (one each, ids 0..k-1, normals up), with region ids
    1..k."""
    sp = _surfaces([(p, np.tile([0.0, 0.0, 1.0], (len(p), 1))) for p in parts])
    return sp, np.arange(1, len(parts) + 1)


def test_fused_legs_under_a_table_top_join_it_and_a_chair_beside_it_does_not():
    top = _box((0.0, 0.0, 0.72), (1.2, 0.8, 0.75))
    # legs 12 cm thick once fused (wider than ``leg_width``), ending 3 cm under the top: cut off at its crease
    legs = [_box((x, y, 0.04), (x + 0.12, y + 0.12, 0.69)) for x in (0.0, 1.08) for y in (0.0, 0.68)]
    chair = _box((1.4, 0.2, 0.04), (1.8, 0.6, 0.9))  # beside the table, as tall as its top and broad
    panel = _box((0.3, 0.76, 0.3), (0.9, 0.8, 0.69))  # a modesty panel: slender one way, under the top
    sp, region = _scan([top, *legs, chair, panel])
    out, joined = _attach_legs(sp, region, CFG)
    assert joined == 4  # the four legs; the panel hangs clear of the floor, the chair is no upright
    assert len(set(out[1:5].tolist()) | {out[0]}) == 1
    assert out[5] != out[0] and out[6] != out[0]


def test_a_desks_back_rail_fused_with_its_wall_joins_the_desk_a_bin_under_it_does_not():
    from rescene_core.segment.geometric.joins import _attach_backs

    planes = [{"kind": "floor", "id": 1}, {"kind": "wall", "id": 2, "normal": [0.0, 1.0, 0.0], "offset": 0.0}]
    # a desk against the wall y = 0: its top 1.2 by 0.6 m at 0.75 m, front legs, and its back rail and leg
    # fused with the wall behind them (5 cm deep, reaching 10 cm past the desk's end along the wall) whose
    # upper part went to the wall: the rail ends 20 cm under the top
    top = _box((0.0, 0.0, 0.72), (1.2, 0.6, 0.75))
    front = _box((0.0, 0.55, 0.04), (1.2, 0.6, 0.69))
    rail = _box((-0.1, 0.0, 0.04), (1.2, 0.05, 0.52))
    bin_ = _box((0.4, 0.0, 0.04), (0.7, 0.25, 0.4))  # a bin against the wall under the desk, 25 cm deep
    panel = _box((1.6, 0.0, 0.04), (2.2, 0.03, 1.0))  # a radiator beside the desk: nothing over it
    sp, region = _scan([top, front, rail, bin_, panel])
    out, joined = _attach_backs(sp, region, planes, CFG)
    assert joined == 1
    assert out[2] == out[0] != out[3] and out[4] not in (out[0], out[3])
    assert _attach_backs(sp, region, planes[:1], CFG)[1] == 0  # no wall found: nothing is a back


def test_a_headboard_against_the_wall_joins_its_bed_a_mirror_beside_it_or_behind_a_desk_does_not():
    from rescene_core.segment.geometric.joins import _attach_backs

    planes = [{"kind": "floor", "id": 1}, {"kind": "wall", "id": 2, "normal": [0.0, 1.0, 0.0], "offset": 0.0}]
    headboard = _box((0.0, 0.0, 0.35), (1.6, 0.075, 1.1))  # 7.5 cm thick against the wall y = 0, seen over 35 cm
    bed = _box((0.0, 0.1, 0.0), (1.6, 2.1, 0.55))  # its mattress and frame, parted at the crease
    nightstand = _box((1.65, 0.0, 0.0), (2.1, 0.4, 0.55))
    mirror = _box((2.2, 0.0, 0.0), (2.8, 0.05, 1.6))  # a floor mirror beside the nightstand, touching it
    sp, region = _scan([headboard, bed, nightstand, mirror])
    out, joined = _attach_backs(sp, region, planes, CFG)
    assert joined == 1 and out[0] == out[1]
    assert len({out[1], out[2], out[3]}) == 3
    # a mirror standing against the wall behind a desk, from under its top to over it, is narrower than it
    desk = _box((3.0, 0.1, 0.0), (4.2, 0.7, 0.75))
    tall = _box((3.3, 0.0, 0.3), (3.9, 0.05, 1.6))
    sp, region = _scan([desk, tall])
    assert _attach_backs(sp, region, planes, CFG)[1] == 0


def test_a_hanging_region_faces_the_room_as_its_wall_does():
    planes = [{"kind": "floor", "id": 1}, {"kind": "wall", "id": 2, "normal": [1.0, 0.0, 0.0], "offset": 0.0}]
    face = _box((0.03, 1.0, 1.8), (0.03, 1.3, 2.1))  # a clock's face 3 cm proud of the wall x = 0
    assert _faces_wall(face, np.tile([1.0, 0.0, 0.0], (len(face), 1)), planes, CFG)
    rng = np.random.default_rng(0)
    stray = rng.normal(size=(len(face), 3))
    stray /= np.linalg.norm(stray, axis=1, keepdims=True)
    stray[:, 0] = 0.3 * np.sign(stray[:, 0])  # a wall surface whose fused normals wander well off the plane's
    stray /= np.linalg.norm(stray, axis=1, keepdims=True)
    assert not _faces_wall(face, stray, planes, CFG)
    assert not _faces_wall(face, np.tile([1.0, 0.0, 0.0], (len(face), 1)), planes[:1], CFG)  # no wall


def test_upright_books_under_a_shelf_board_are_stored_a_flat_stack_or_a_monitor_is_not():
    from rescene_core.segment.geometric import SegmentConfig
    from rescene_core.segment.geometric.support import _stored_upright

    cfg = SegmentConfig()
    rng = np.random.default_rng(0)
    # a bookcase cell: the board over it 5 cm above a 26 cm row of books 18 cm deep, 40 cm wide
    board = np.c_[rng.uniform(0, 0.7, 300), rng.uniform(0, 0.3, 300), np.full(300, 0.71)]
    row_lo, row_hi = np.array([0.05, 0.01, 0.4]), np.array([0.45, 0.19, 0.66])
    assert _stored_upright(board, row_lo, row_hi, cfg)
    # a book stack on the same shelf lies flat (12 cm tall, 20 cm deep)
    assert not _stored_upright(board, np.array([0.05, 0.01, 0.4]), np.array([0.25, 0.21, 0.52]), cfg)
    # a monitor on a desk is upright, but nothing of the desk lies over it
    desk = np.c_[rng.uniform(0, 1.2, 300), rng.uniform(0, 0.6, 300), np.full(300, 0.75)]
    assert not _stored_upright(desk, np.array([0.3, 0.2, 0.75]), np.array([0.9, 0.36, 1.15]), cfg)


def test_a_lamp_pole_reaching_into_its_open_shade_finds_the_shade():
    from rescene_core.segment.geometric.joins import _hollow_over

    # regions: 1 the pole (3 cm wide, up to 1.30 m), 2 the shade (1.25-1.55 m, 40 cm wide, hollow), 3 a
    # bookcase beside it from the floor, 4 a table whose top lies far under the pole's end
    lo = np.array([[np.inf] * 3, [0.0, 0.0, 0.04], [-0.2, -0.2, 1.25], [-1.0, -1.0, 0.0], [-0.5, -0.5, 0.0]])
    hi = np.array([[-np.inf] * 3, [0.03, 0.03, 1.30], [0.23, 0.23, 1.55], [1.0, 1.0, 1.9], [0.5, 0.5, 0.75]])
    slender = np.array([False, True, False, False, False])
    assert _hollow_over(1, lo, hi, slender, 0.04) == 2
    lo[2, 2] = 1.45  # a shade beginning 15 cm over the pole's end is no part of it
    assert _hollow_over(1, lo, hi, slender, 0.04) == 0


def test_a_monitor_on_a_desk_is_split_off_at_the_top_and_the_desks_own_back_is_not():
    from rescene_core.segment.geometric.tops import split_bodies_on_tops

    top = _box((0.0, 0.0, 0.75), (1.2, 0.6, 0.75))
    legs = [_box((x, y, 0.04), (x + 0.05, y + 0.05, 0.725)) for x in (0.0, 1.15) for y in (0.0, 0.55)]
    # a monitor: a base plate 2.5 cm over the top (no crease, one region with the desk) and its screen
    base = _box((0.5, 0.3, 0.775), (0.7, 0.45, 0.775))
    screen = _box((0.4, 0.425, 0.8), (0.8, 0.45, 1.1))
    back = _box((0.0, 0.6, 0.775), (1.2, 0.6, 1.0))  # the desk's back board, as wide as its top
    corner = _box((0.0, 0.0, 0.775), (0.2, 0.15, 0.9))  # a box at the desk's corner: the top beyond on 2 sides
    sp, _ = _scan([top, *legs, base, screen, back, corner])
    region = np.ones(sp.graph.size, np.int64)
    sp2, region2, which2, split = split_bodies_on_tops(sp, region, np.zeros(sp.graph.size, np.int64), CFG)
    point_region = region2[sp2.graph.label]
    monitor = np.r_[np.zeros(len(top) + sum(map(len, legs)), bool), np.ones(len(base) + len(screen), bool)]
    monitor = np.r_[monitor, np.zeros(len(back) + len(corner), bool)]
    assert split == 1 and len(which2) == sp2.graph.size
    assert len(np.unique(point_region[monitor])) == 1 and (point_region[monitor] != 1).all()
    assert (point_region[~monitor] == 1).all()  # the top, the legs, the back board and the corner box


def test_a_lamp_whose_shade_overhangs_a_small_nightstand_is_split_off_at_its_foot():
    from rescene_core.segment.geometric.tops import split_bodies_on_tops

    # a nightstand 44 by 34 cm, its top at 0.56 m; a lamp's base disc (16 cm) and stem in its middle, the
    # shade (30 cm) reaching to within 2-4 cm of the top's edges; no crease or colour step parts the base
    top = _box((0.0, 0.0, 0.56), (0.45, 0.35, 0.56))
    body = _box((0.0, 0.0, 0.05), (0.45, 0.35, 0.535))
    base = _box((0.15, 0.1, 0.585), (0.3, 0.25, 0.6))
    stem = _box((0.225, 0.175, 0.625), (0.225, 0.175, 0.8))
    shade = _box((0.075, 0.025, 0.825), (0.375, 0.325, 1.0))
    lamp = len(base) + len(stem) + len(shade)
    sp, _ = _scan([top, body, base, stem, shade])
    region = np.ones(sp.graph.size, np.int64)
    sp2, region2, _, split = split_bodies_on_tops(sp, region, np.zeros(sp.graph.size, np.int64), CFG)
    point_region = region2[sp2.graph.label]
    assert split == 1
    assert (point_region[-lamp:] == point_region[-1]).all() and point_region[-1] != 1
    assert (point_region[:-lamp] == 1).all()


def test_a_stack_as_deep_as_its_shelf_is_held_by_it_a_back_or_a_divider_is_not():
    from rescene_core.segment.geometric.support import _held_by_top

    # a bookcase shelf 64 cm wide and 27 cm deep at z = 0.5, seen around what stands on it
    shelf = _box((0.0, 0.0, 0.5), (0.64, 0.27, 0.5))[:, :2]

    def top_around(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        hidden = np.all((shelf >= lo[:2]) & (shelf <= hi[:2]), axis=1)
        return shelf[~hidden]

    # a book stack 20 cm wide, 13 cm tall, as deep as the shelf (26 of 27 cm), in the middle of its width
    stack = np.array([0.22, 0.0, 0.52]), np.array([0.42, 0.26, 0.65])
    assert _held_by_top(*stack, top_around(*stack), CFG)
    # the same stack pushed against the shelf's end: the shelf reaches beyond it on one side only
    end = np.array([0.0, 0.0, 0.52]), np.array([0.2, 0.26, 0.65])
    assert not _held_by_top(*end, top_around(*end), CFG)
    # a divider board across the shelf, 2 cm thick: a panel of the case
    divider = np.array([0.31, 0.0, 0.52]), np.array([0.33, 0.27, 0.8])
    assert not _held_by_top(*divider, top_around(*divider), CFG)
    # a chair's back spans its seat's width at the seat's rear edge; a box in the seat's middle stands on it
    seat = _box((0.0, 0.0, 0.45), (0.45, 0.45, 0.45))[:, :2]
    back = np.array([0.0, 0.4, 0.47]), np.array([0.45, 0.45, 0.9])
    assert not _held_by_top(*back, seat[seat[:, 1] < 0.4], CFG)
    box = np.array([0.15, 0.15, 0.47]), np.array([0.3, 0.3, 0.6])
    inner = np.all((seat >= box[0][:2]) & (seat <= box[1][:2]), axis=1)
    assert _held_by_top(*box, seat[~inner], CFG)
    # a body as large as the top both ways is the piece's own
    assert not _held_by_top(np.array([0.0, 0.0, 0.47]), np.array([0.45, 0.45, 0.6]), seat, CFG)


def test_a_stack_flush_with_a_desks_front_edge_is_held_by_the_desk_seen_left_and_right_of_it():
    from rescene_core.segment.geometric.support import _held_by_top

    # a desk 1.2 m wide and 0.6 m deep, its top at z = 0.75; a book stack 30 cm deep stands flush with its
    # front edge, a monitor hides the desk behind it: the desk is seen beyond it left and right only
    desk = _box((0.0, 0.0, 0.75), (1.2, 0.6, 0.75))[:, :2]

    def seen_around(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        behind = (desk[:, 0] >= lo[0]) & (desk[:, 0] <= hi[0]) & (desk[:, 1] >= lo[1])
        return desk[~behind]

    stack = np.array([0.5, 0.0, 0.76]), np.array([0.72, 0.3, 0.88])
    assert _held_by_top(*stack, seen_around(*stack), CFG)
    # seen beyond it on one side only (a lamp hides the right), it is not held
    left = seen_around(*stack)
    assert not _held_by_top(*stack, left[left[:, 0] < 0.5], CFG)
    # a board 3 cm thick standing there is a panel of the desk
    board = np.array([0.5, 0.0, 0.76]), np.array([0.53, 0.3, 0.95])
    assert not _held_by_top(*board, seen_around(*board), CFG)


def test_a_wall_behind_a_monitor_counts_as_a_side_of_the_desk_beyond_it():
    from rescene_core.segment.geometric.support import _held_by_top, _sides_at_wall

    # a desk 1.2 m wide and 0.6 m deep against the wall y = 0, its top at z = 0.75; a monitor 50 cm wide at
    # the back, 2 cm off the wall; the desk is seen in front of it and left of it (a lamp hides the right)
    desk = _box((0.0, 0.0, 0.75), (1.2, 0.6, 0.75))[:, :2]
    wall = {"kind": "wall", "normal": [0.0, 1.0, 0.0], "offset": 0.0, "span": [-5.0, 5.0]}  # along x

    def seen_around(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        hidden = np.all((desk >= lo[:2]) & (desk <= hi[:2]), axis=1) | (desk[:, 0] > hi[0])
        return desk[~hidden]

    monitor = np.array([0.4, 0.02, 0.76]), np.array([0.9, 0.2, 1.2])
    top = seen_around(*monitor)
    at_wall = _sides_at_wall(*monitor, 0.75, [wall], CFG)
    assert at_wall.tolist() == [False, False, True, False]
    assert not _held_by_top(*monitor, top, CFG)  # two sides seen beyond it: a hutch would look the same
    assert _held_by_top(*monitor, top, CFG, walled=at_wall)
    # the wall is no side where the desk is not seen across from it (the desk's front hidden too)
    assert not _held_by_top(*monitor, top[top[:, 1] < 0.25], CFG, walled=at_wall)
    # moved 20 cm off the wall, the monitor has no side at it
    off = np.array([0.4, 0.22, 0.76]), np.array([0.9, 0.4, 1.2])
    assert not _sides_at_wall(*off, 0.75, [wall], CFG).any()
    # a bed's pillows, 1.6 m along the wall at its head, are the bed's own
    bed = _box((0.0, 0.0, 0.5), (2.0, 2.1, 0.5))[:, :2]
    pillows = np.array([0.2, 0.02, 0.52]), np.array([1.8, 0.5, 0.7])
    assert not _sides_at_wall(*pillows, 0.5, [wall], CFG).any()
    assert not _held_by_top(*pillows, bed[bed[:, 1] > 0.55], CFG, walled=_sides_at_wall(*pillows, 0.5, [wall], CFG))
    # a wall beyond the end of the seen stretch of wall is none
    short = dict(wall, span=[-0.3, 0.0])
    assert not _sides_at_wall(*monitor, 0.75, [short], CFG).any()


def test_a_stack_as_deep_as_its_bookcase_rests_on_its_shelf_unless_it_lies_at_the_shelfs_end():
    # a bookcase 64 cm wide, 27 cm deep; its shelf at z = 0.5, seen around the stack
    shelf = _box((0.0, 0.0, 0.5), (0.64, 0.27, 0.5))
    big_lo, big_hi = np.array([0.0, 0.0, 0.0]), np.array([0.64, 0.27, 1.8])
    for stack, rests in (
        ((np.array([0.22, 0.0, 0.5]), np.array([0.42, 0.25, 0.62])), True),  # 25 of 27 cm deep, mid-shelf
        ((np.array([0.22, 0.05, 0.5]), np.array([0.42, 0.2, 0.57])), True),  # two books, 7 cm
        ((np.array([0.22, 0.05, 0.5]), np.array([0.42, 0.2, 0.53])), False),  # 3 cm: a board of the case
        ((np.array([0.0, 0.0, 0.5]), np.array([0.2, 0.25, 0.62])), False),  # at the shelf's end
    ):
        hidden = np.all((shelf[:, :2] >= stack[0][:2]) & (shelf[:, :2] <= stack[1][:2]), axis=1)
        assert _rests_on(shelf[~hidden], *stack, big_lo, big_hi, MIN_TOP, CFG) is rests


def test_a_lamps_stem_under_its_shade_joins_it_a_stack_under_a_stack_or_its_nightstand_does_not():
    nightstand = _box((0.2, 0.2, 0.0), (0.8, 0.8, 0.475))
    base = np.concatenate([_box((0.4, 0.4, 0.5), (0.6, 0.6, 0.525)), _box((0.5, 0.5, 0.55), (0.5, 0.5, 0.75))])
    shade = _box((0.35, 0.35, 0.775), (0.65, 0.65, 0.95))  # parted from the stem by its colour and rim
    lower = _box((1.5, 0.3, 0.5), (1.75, 0.55, 0.6))  # two book stacks, one on the other, as wide
    upper = _box((1.5, 0.3, 0.625), (1.75, 0.55, 0.7))
    table = _box((1.3, 0.1, 0.0), (2.0, 0.8, 0.475))  # what the stacks stand on
    sp, region = _scan([nightstand, base, shade, lower, upper, table])
    out, joined = _join_stems(sp, region, CFG, WALL)
    assert joined == 1
    assert out[1] == out[2] != out[0]  # the stem with its shade, the nightstand it stands on apart
    assert out[3] != out[4]  # the lower stack's top is as broad as the stack above: a body, not a stem
    # a stem reaching out from under its shade (a floor lamp's arm beside a shelf) stays apart
    sp, region = _scan([base + [0.3, 0.0, 0.0], shade])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0


def test_a_wall_shelfs_bracket_hanging_under_its_board_joins_it_a_stack_standing_under_a_stack_does_not():
    board = _box((0.0, 0.0, 1.3), (0.9, 0.25, 1.35))  # a wall shelf's board against the wall y = 0
    bracket = _box((0.1, 0.0, 1.15), (0.15, 0.2, 1.275))  # as deep as the board, parted from it by colour
    sp, region = _scan([board, bracket])
    out, joined = _join_stems(sp, region, CFG, WALL)
    assert joined == 1 and out[0] == out[1]
    # the same under a second board 15 cm below it: it stands on that board (two stacks on a shelf)
    sp, region = _scan([board, bracket, _box((0.0, 0.0, 1.1), (0.9, 0.25, 1.125))])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0
    # the same pair 50 cm off the wall: nothing fixes the lower one to a wall, so it is no bracket
    sp, region = _scan([board + [0.0, 0.5, 0.0], bracket + [0.0, 0.5, 0.0]])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0


def test_a_lamps_stem_whose_top_the_fusion_lost_joins_its_shade_a_stem_far_under_it_does_not():
    shade = _box((0.35, 0.35, 0.85), (0.65, 0.65, 1.0))
    # a base broader than the shade on one side (8 cm past it), its stem ending 6 cm under the shade
    base = np.concatenate([_box((0.4, 0.4, 0.5), (0.73, 0.6, 0.525)), _box((0.5, 0.5, 0.55), (0.5, 0.5, 0.79))])
    sp, region = _scan([base, shade])
    out, joined = _join_stems(sp, region, CFG, WALL)
    assert joined == 1 and out[0] == out[1]
    # the same stem ending 15 cm under the shade: two things, one over the other
    sp, region = _scan([base, shade + [0.0, 0.0, 0.09]])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0
    # a base mostly beyond the shade's footprint stays apart even when its stem ends under the shade
    wide = np.concatenate([_box((0.45, 0.4, 0.5), (1.2, 0.6, 0.525)), _box((0.5, 0.5, 0.55), (0.5, 0.5, 0.83))])
    sp, region = _scan([wide, shade])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0


def test_a_plants_pot_under_its_foliage_joins_it_a_stack_under_one_flush_with_its_side_does_not():
    pot = _box((0.4, 0.4, 0.0), (0.75, 0.75, 0.3))  # 35 cm across, its rim at 0.3 m
    foliage = _box((0.25, 0.25, 0.325), (0.9, 0.9, 0.8))  # 65 cm across, 15 cm past the pot all round
    sp, region = _scan([pot, foliage])
    out, joined = _join_stems(sp, region, CFG, WALL)
    assert joined == 1 and out[0] == out[1]
    # the upper region flush with the lower one's side (a stack on a broader stack, pushed to its end)
    sp, region = _scan([pot, foliage + [0.15, 0.0, 0.0]])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0
    # leaves hanging 10 cm below the pot's rim beside it, 10 to 15 cm out from it
    hanging = np.concatenate([foliage, _box((0.25, 0.25, 0.2), (0.3, 0.9, 0.3))])
    sp, region = _scan([pot, hanging])
    assert _join_stems(sp, region, CFG, WALL)[1] == 1
    # the same reaching down within the pot's own footprint stays apart: nothing hangs beside a pot there
    sp, region = _scan([pot, np.concatenate([foliage, _box((0.45, 0.45, 0.2), (0.7, 0.5, 0.3))])])
    assert _join_stems(sp, region, CFG, WALL)[1] == 0


def test_after_the_splits_a_lamps_base_split_off_joins_its_shade_a_stack_split_off_a_shelf_does_not():
    shade = _box((0.35, 0.35, 0.775), (0.65, 0.65, 0.95))
    base = np.concatenate([_box((0.4, 0.4, 0.5), (0.6, 0.6, 0.525)), _box((0.5, 0.5, 0.55), (0.5, 0.5, 0.75))])
    books = _box((1.0, 0.0, 0.3), (1.7, 0.3, 0.66))  # books on the board over a shelf, left apart from the case
    stack = _box((1.1, 0.05, 0.08), (1.35, 0.28, 0.26))  # a stack split off the shelf under that board
    sp, region = _scan([shade, books, base, stack])  # regions 3 and 4 came off tops
    out, joined = _join_stems(sp, region, CFG, WALL, split_from=3)
    assert joined == 1 and out[2] == out[0] and out[3] not in (out[0], out[1])
    # only what the splits made joins: the same shade and base, both there before, are the first pass's
    assert _join_stems(sp, region, CFG, WALL, split_from=5)[1] == 0


def test_a_row_of_books_left_apart_joins_its_bookcase_a_flat_stack_or_a_row_with_no_board_over_it_does_not():
    from rescene_core.segment.geometric.cases import _join_stored_rows

    def case(board: bool) -> list[tuple[np.ndarray, np.ndarray]]:
        faces = [
            _faces((0.0, 0.0, 0.0), (0.0, 0.3, 1.0), (1, 0, 0)),  # side panels' inner faces
            _faces((0.8, 0.0, 0.0), (0.8, 0.3, 1.0), (-1, 0, 0)),
            _faces((0.025, 0.0, 0.0), (0.775, 0.0, 1.0), (0, 1, 0)),  # the back
            _faces((0.025, 0.025, 0.5), (0.775, 0.3, 0.5), (0, 0, 1)),  # a shelf
        ]
        return faces + ([_faces((0.025, 0.025, 0.8), (0.775, 0.3, 0.8), (0, 0, -1))] if board else [])

    # upright books 25 cm tall, 17.5 cm deep, their tops 2.5 cm under the board over them
    row = [_faces((0.025, 0.2, 0.525), (0.4, 0.2, 0.75), (0, 1, 0)), _up((0.025, 0.025, 0.775), (0.4, 0.175, 0.775))]
    stack = [_up((0.5, 0.025, 0.6), (0.75, 0.225, 0.6)), _faces((0.5, 0.25, 0.525), (0.75, 0.25, 0.575), (0, 1, 0))]
    for board in (True, False):
        parts = [case(board), row, stack]
        sp = _surfaces([f for part in parts for f in part])
        region = np.repeat(np.arange(1, 4), [len(part) for part in parts])
        out, joined = _join_stored_rows(sp, region, CFG)
        assert joined == int(board)
        assert (out[-2:] == 3).all()  # the stack lies flat: a body on the shelf, never the case's
        assert (out[len(parts[0]) : -2] == (1 if board else 2)).all()


def _lying_on(top: np.ndarray, body: np.ndarray) -> np.ndarray:
    """The points of a top [k, 3] outside a body's footprint (the top under a body is hidden)."""
    lo, hi = body[:, :2].min(axis=0), body[:, :2].max(axis=0)
    return top[~np.all((top[:, :2] >= lo) & (top[:, :2] <= hi), axis=1)]


def test_a_pillow_on_a_mattress_joins_the_bed_a_lamp_on_it_or_a_pillow_on_a_table_does_not():
    # a double bed: its mattress top 1.4 by 2.0 m at z = 0.52, its side down to the frame at 0.3
    pillow = _box((0.1, 0.1, 0.545), (0.7, 0.5, 0.645))  # 10 cm thick on 60 by 40 cm, touching the top
    lamp = _box((1.0, 1.2, 0.545), (1.2, 1.4, 0.9))  # taller than it is broad
    mattress = _lying_on(_lying_on(_box((0.0, 0.0, 0.52), (1.4, 2.0, 0.52)), pillow), lamp)
    side = _box((0.0, 0.0, 0.3), (0.0, 2.0, 0.5))
    sp, region = _scan([np.concatenate([mattress, side]), pillow, lamp])
    out, joined = _join_bedding(sp, region, CFG)
    assert joined == 1 and out[1] == out[0] and out[2] != out[0]
    # the pillow on a coffee table (1.0 by 0.6 m, too small) or on a dining table (2.0 by 1.0 m at 0.75 m,
    # too high) stays apart from it
    up = np.array([0.0, 0.0, 0.23])
    for table, body in (
        (_box((-0.2, 0.0, 0.52), (0.8, 0.6, 0.52)), pillow),
        (_box((-0.3, -0.2, 0.75), (1.7, 0.8, 0.75)), pillow + up),
    ):
        sp, region = _scan([_lying_on(table, body), body])
        assert _join_bedding(sp, region, CFG)[1] == 0


def test_a_low_top_carries_a_body_only_where_a_board_of_the_case_lies_over_it():
    # a bookcase's lowest shelf, 7 cm above the floor, with a stack on it
    shelf = _box((0.0, 0.0, 0.07), (0.64, 0.27, 0.07))
    big_lo, big_hi = np.array([0.0, 0.0, 0.0]), np.array([0.64, 0.27, 1.8])
    stack = np.array([0.22, 0.02, 0.07]), np.array([0.42, 0.22, 0.2])
    hidden = np.all((shelf[:, :2] >= stack[0][:2]) & (shelf[:, :2] <= stack[1][:2]), axis=1)
    tops = shelf[~hidden]
    assert not _rests_on(tops, *stack, big_lo, big_hi, MIN_TOP, CFG)  # too low for any top
    assert _rests_on(tops, *stack, big_lo, big_hi, CFG.stored_min_height, CFG)  # a shelf of a case
    board = _box((0.0, 0.0, 0.45), (0.64, 0.27, 0.45))
    assert _under_board(board, *stack, CFG)
    assert not _under_board(board[board[:, 0] > 0.5], *stack, CFG)  # the board ends before the stack


def _faces(lo: tuple[float, float, float], hi: tuple[float, float, float], normal: tuple[float, float, float]):
    """Points [n, 3] on a STEP grid over a flat face (one of lo, hi's axes equal) and their normals [n, 3]."""
    p = _box(lo, hi)
    return p, np.tile(np.asarray(normal, float), (len(p), 1))


def _surfaces(
    faces: list[tuple[np.ndarray, np.ndarray]], colours: list[tuple[float, float, float]] | None = None
) -> ScanPoints:
    """ScanPoints of oriented faces, one superpoint each, coloured alike (geometry alone parts them) or each
    face in its colour of ``colours`` (RGB in [0, 1])."""
    pts = np.concatenate([f[0] for f in faces])
    nrm = np.concatenate([f[1] for f in faces])
    label = np.concatenate([np.full(len(f[0]), i) for i, f in enumerate(faces)])
    if colours is None:
        col = np.full((len(pts), 3), 0.5)
    else:
        col = np.concatenate(
            [np.tile(np.asarray(c, float), (len(f[0]), 1)) for f, c in zip(faces, colours, strict=True)]
        )
    edges = point_graph(pts, STEP * 1.75)
    _, concave, step = edge_weights(pts, nrm, col, edges, 1.0)
    g = superpoint_graph(pts, nrm, col, label, edges, concave, step)
    return ScanPoints(pts, nrm, col, np.zeros(len(pts), np.int64), np.arange(len(pts)), edges, concave, step, g)


def _bookcase(board_over_stack: bool) -> tuple[list[tuple[np.ndarray, np.ndarray]], int]:
    """The seen faces of a bookcase 0.8 m wide, 0.3 m deep (back at y = 0) with a book stack on its lowest
    shelf (z = 0.07) against the back panel and a row of upright books on the shelf at z = 0.5; with
    ``board_over_stack`` False the case ends at the shelf under the stack (a sofa's back behind a cushion).
    Returns the faces and how many of the first belong to the stack."""
    stack = [
        _faces((0.2, 0.0, 0.2), (0.4, 0.225, 0.2), (0, 0, 1)),  # its top
        _faces((0.2, 0.25, 0.075), (0.4, 0.25, 0.175), (0, 1, 0)),  # its front
        _faces((0.175, 0.0, 0.075), (0.175, 0.225, 0.175), (-1, 0, 0)),  # its sides
        _faces((0.425, 0.0, 0.075), (0.425, 0.225, 0.175), (1, 0, 0)),
    ]
    top = 1.0 if board_over_stack else 0.45
    back = _faces((0.025, -0.025, 0.1), (0.775, -0.025, top), (0, 1, 0))
    behind = (back[0][:, 0] > 0.15) & (back[0][:, 0] < 0.45) & (back[0][:, 2] < 0.225)  # hidden by the stack
    case = [
        _faces((0.0, -0.025, 0.0), (0.0, 0.3, top), (1, 0, 0)),  # side panels' inner faces
        _faces((0.8, -0.025, 0.0), (0.8, 0.3, top), (-1, 0, 0)),
        (back[0][~behind], back[1][~behind]),
        _faces((0.025, 0.325, 0.0), (0.775, 0.325, 0.05), (0, 1, 0)),  # the plinth's front
    ]
    shelf = _faces((0.025, 0.0, 0.075), (0.775, 0.3, 0.075), (0, 0, 1))
    hidden = (shelf[0][:, 0] > 0.15) & (shelf[0][:, 0] < 0.45) & (shelf[0][:, 1] < 0.25)
    case.append((shelf[0][~hidden], shelf[1][~hidden]))
    if board_over_stack:
        case += [
            _faces((0.025, 0.0, 0.475), (0.775, 0.3, 0.475), (0, 0, -1)),  # the board's underside ...
            _faces((0.55, 0.0, 0.5), (0.775, 0.3, 0.5), (0, 0, 1)),  # ... and its top beside the row
            _faces((0.025, 0.2, 0.525), (0.5, 0.2, 0.75), (0, 1, 0)),  # upright books' spines
            _faces((0.025, 0.0, 0.775), (0.5, 0.175, 0.775), (0, 0, 1)),  # their tops
            _faces((0.525, 0.0, 0.525), (0.525, 0.175, 0.75), (1, 0, 0)),
            _faces((0.025, 0.0, 0.975), (0.775, 0.3, 0.975), (0, 0, -1)),  # the case's top board
        ]
    return stack + case, sum(len(f[0]) for f in stack)


def test_a_stack_against_a_bookcases_back_is_split_off_a_cushion_with_nothing_over_it_is_not():
    from rescene_core.segment.geometric.tops import split_bodies_on_tops

    for board_over_stack in (True, False):
        faces, n_stack = _bookcase(board_over_stack)
        sp = _surfaces(faces)
        region = np.ones(sp.graph.size, np.int64)
        sp2, region2, _, split = split_bodies_on_tops(sp, region, np.zeros(sp.graph.size, np.int64), CFG)
        point_region = region2[sp2.graph.label]
        stack = np.arange(len(sp.points)) < n_stack
        above = sp.points[:, 2] > 0.075 + CFG.top_clearance
        if board_over_stack:
            assert split == 1  # the stack; the upright books stay with the case
            assert len(np.unique(point_region[stack & above])) == 1 and (point_region[stack & above] != 1).all()
            assert (point_region[~stack] == 1).all()
        else:
            assert split == 0 and (point_region == 1).all()


def test_a_stack_of_another_colour_is_parted_from_its_case_where_no_crease_parts_it_one_of_the_cases_is_not():
    from rescene_core.segment.geometric.colour import _hue_rest
    from rescene_core.segment.geometric.tops import split_bodies_on_tops

    wood = np.array([0.58, 0.47, 0.37])
    k, rest = _hue_rest(np.array([wood, 0.6 * wood, [0.2, 0.3, 0.6]]), wood)
    assert np.allclose(k[:2], [1.0, 0.6]) and np.allclose(rest[:2], 0.0) and rest[2] > CFG.case_tint

    faces, n_stack = _bookcase(board_over_stack=True)
    n_faces_stack = 4  # the stack's faces come first, then the case's: sides, back, plinth, shelf, boards ...
    rows = {7, 8, 9}  # ... and the upright books' spines, tops and end
    # the back panel seen in part, broken where noise left holes: no column of it counts as the frame
    cfg = CFG.model_copy(update={"frame_column_least": 10**6})
    for stack_colour, split_off in (((0.2, 0.3, 0.6), True), (tuple(0.7 * wood), False)):
        colours = [stack_colour] * n_faces_stack
        colours += [
            (0.8, 0.2, 0.2) if i - n_faces_stack in rows else tuple(wood) for i in range(n_faces_stack, len(faces))
        ]
        sp = _surfaces(faces, colours)
        sp.concave[:] = False  # the fused surface rounded every corner: no crease parts the stack from the back
        region = np.ones(sp.graph.size, np.int64)
        sp2, region2, _, split = split_bodies_on_tops(sp, region, np.zeros(sp.graph.size, np.int64), cfg)
        point_region = region2[sp2.graph.label]
        stack = np.arange(len(sp.points)) < n_stack
        above = sp.points[:, 2] > 0.075 + CFG.top_clearance
        if split_off:  # a stack of books; the row of upright books, of another colour too, stays the case's
            assert split == 1
            assert len(np.unique(point_region[stack & above])) == 1 and (point_region[stack & above] != 1).all()
            assert (point_region[~stack] == 1).all()
        else:  # of the case's colour, shaded: nothing parts it from the case
            assert split == 0 and (point_region == 1).all()


def _up(lo: tuple[float, float, float], hi: tuple[float, float, float]):
    return _faces(lo, hi, (0.0, 0.0, 1.0))


def _side(lo: tuple[float, float, float], hi: tuple[float, float, float]):
    return _faces(lo, hi, (1.0, 0.0, 0.0))


def _split(
    faces: list[tuple[np.ndarray, np.ndarray]], colours: list[tuple[float, float, float]] | None = None
) -> tuple[np.ndarray, int]:
    """The region of each point after ``split_bodies_on_tops`` on one region holding all ``faces`` (coloured
    as ``_surfaces`` colours them)."""
    from rescene_core.segment.geometric.tops import split_bodies_on_tops

    sp = _surfaces(faces, colours)
    region = np.ones(sp.graph.size, np.int64)
    sp2, region2, _, split = split_bodies_on_tops(sp, region, np.zeros(sp.graph.size, np.int64), CFG)
    return region2[sp2.graph.label], split


def test_chairs_beside_a_table_are_parted_from_it_its_legs_and_what_stands_on_it_are_not():
    # a dining table 1.4 by 0.9 m, its top at 0.75 m; a box on its corner hides the top there
    top = _up((0.0, 0.0, 0.75), (1.4, 0.9, 0.75))
    box = (top[0][:, 0] > 1.2) & (top[0][:, 1] > 0.7)
    table = [(top[0][~box], top[1][~box]), _side((0.0, 0.0, 0.725), (0.0, 0.9, 0.725))]
    table += [_side((x, y, 0.05), (x + 0.05, y + 0.05, 0.7)) for x in (0.05, 1.3) for y in (0.05, 0.8)]
    table += [_up((1.225, 0.725, 0.9), (1.4, 0.9, 0.9)), _side((1.2, 0.7, 0.775), (1.2, 0.9, 0.875))]
    # a chair whose back stands 7.5 cm off the table's long edge (y = 0), reaching 17 cm over its top; the
    # fused surface bridges the gap under the back's upper rail
    chair = [
        _up((0.45, -0.55, 0.45), (0.9, -0.1, 0.45)),
        _faces((0.45, -0.075, 0.475), (0.9, -0.075, 0.925), (0, 1, 0)),
    ]
    chair += [_side((x, y, 0.05), (x + 0.025, y + 0.025, 0.425)) for x in (0.45, 0.875) for y in (-0.55, -0.1)]
    bridge = _faces((0.5, -0.05, 0.8), (0.85, -0.025, 0.8), (0, 1, 0))
    point_region, split = _split(table + chair + [bridge])
    n_table = sum(len(f[0]) for f in table)
    n_chair = sum(len(f[0]) for f in chair)
    on_chair = point_region[n_table : n_table + n_chair]
    assert split == 1
    assert (point_region[:n_table] == 1).all()  # its top, its legs and the box on its corner
    assert len(np.unique(on_chair)) == 1 and on_chair[0] != 1


def test_chairs_pushed_in_on_both_sides_of_a_table_are_parted_from_it_before_their_seats_carry_it():
    # a dining table 1.4 by 0.9 m, its top at 0.75 m, its legs seen only above the seats of the chairs pushed
    # in on its long sides; each chair's back stands 7.5 cm off the table's edge, bridged to it. The seats,
    # lower than the top and beyond it on both sides, are a top of the region too, on which the table with
    # the chairs' backs would stand as a body
    table = [_up((0.0, 0.0, 0.75), (1.4, 0.9, 0.75)), _side((0.0, 0.0, 0.725), (0.0, 0.9, 0.725))]
    table += [_side((x, y, 0.5), (x + 0.05, y + 0.05, 0.7)) for x in (0.05, 1.3) for y in (0.05, 0.8)]
    chairs = []
    for y_seat, y_back, y_bridge, facing in ((-0.55, -0.075, -0.05, 1), (0.975, 0.975, 0.925, -1)):
        chair = [
            _up((0.45, y_seat, 0.45), (0.9, y_seat + 0.45, 0.45)),
            _faces((0.45, y_back, 0.475), (0.9, y_back, 0.925), (0, facing, 0)),
        ]
        chair += [
            _side((x, y, 0.05), (x + 0.025, y + 0.025, 0.425)) for x in (0.45, 0.875) for y in (y_seat, y_seat + 0.45)
        ]
        chairs.append(chair + [_faces((0.5, y_bridge, 0.75), (0.85, y_bridge + 0.025, 0.75), (0, facing, 0))])
    point_region, split = _split(table + chairs[0] + chairs[1])
    n_table, n_chair = sum(len(f[0]) for f in table), sum(len(f[0]) for f in chairs[0])
    assert split == 2
    assert (point_region[:n_table] == 1).all()
    first, second = point_region[n_table : n_table + n_chair], point_region[n_table + n_chair :]
    for chair in (first, second):
        assert len(np.unique(chair[: -len(chairs[0][-1][0])])) == 1 and chair[0] != 1  # the bridge may go either way
    assert first[0] != second[0]


def test_a_strip_of_wall_standing_beside_a_cabinets_top_is_not_parted_from_it():
    # a cabinet 1 m wide, 0.45 m deep, its top at 0.85 m, and a strip of a wall's corner beside its end, 12.5 by
    # 12.5 cm and 1.1 m tall, in the same region
    cabinet = [_up((0.0, 0.0, 0.85), (1.0, 0.45, 0.85)), _faces((0.0, 0.45, 0.05), (1.0, 0.45, 0.825), (0, 1, 0))]
    strip = [_side((x, 0.0, 0.05), (x, 0.125, 1.15)) for x in (1.1, 1.225)]
    strip += [_faces((1.125, y, 0.05), (1.2, y, 1.15), (0, 1, 0)) for y in (0.0, 0.125)]
    point_region, split = _split(cabinet + strip)
    assert split == 0 and (point_region == 1).all()


def test_the_sides_under_a_top_seen_in_part_and_a_sofas_seat_before_its_back_are_not_parted():
    # a wardrobe 1.2 by 0.6 m, 2 m tall, whose top is seen only along its front (15 cm): its sides and
    # back lie beyond what is seen of the top but end at it
    strip = _up((0.0, 0.0, 2.0), (1.2, 0.15, 2.0))
    wardrobe = [strip, _faces((0.0, 0.0, 0.05), (1.2, 0.0, 1.975), (0, -1, 0))]
    wardrobe += [_side((x, 0.025, 0.05), (x, 0.6, 1.975)) for x in (0.0, 1.2)]
    point_region, split = _split(wardrobe)
    assert split == 0 and (point_region == 1).all()
    # a sofa 2 m wide: its back's top at 0.85 m is 20 cm deep, its seat before it is lower
    sofa = [_up((0.0, 0.7, 0.85), (2.0, 0.9, 0.85)), _faces((0.0, 0.7, 0.45), (2.0, 0.7, 0.825), (0, -1, 0))]
    sofa += [_up((0.0, 0.0, 0.45), (2.0, 0.675, 0.45)), _faces((0.0, 0.0, 0.05), (2.0, 0.0, 0.425), (0, -1, 0))]
    point_region, split = _split(sofa)
    assert split == 0 and (point_region == 1).all()


def test_a_stack_at_a_shelfs_hidden_end_under_the_next_board_is_split_off_the_case_frame_above_it():
    # a bookcase's shelf at 0.9 m, 0.8 m wide and 0.3 m deep, seen up to x = 0.45 and along its front edge: a
    # stack at x 0.5-0.7 hides the rest; the case's sides and the next board over the shelf are all of the
    # case the region holds above the shelf, joined to nothing under it
    case = [_up((0.0, 0.0, 0.9), (0.45, 0.3, 0.9)), _up((0.475, 0.3, 0.9), (0.8, 0.3, 0.9))]
    case += [_faces((0.0, 0.0, 1.3), (0.8, 0.3, 1.3), (0, 0, -1))]
    case += [_side((x, 0.0, 0.925), (x, 0.3, 1.275)) for x in (0.0, 0.8)]
    stack = [_up((0.5, 0.025, 1.0), (0.7, 0.25, 1.0)), _faces((0.5, 0.275, 0.925), (0.7, 0.275, 0.975), (0, 1, 0))]
    stack += [_side((x, 0.025, 0.925), (x, 0.25, 0.975)) for x in (0.475, 0.725)]
    point_region, split = _split(case + stack)
    n_case = sum(len(f[0]) for f in case)
    assert split == 1
    assert (point_region[:n_case] == 1).all()
    assert len(np.unique(point_region[n_case:])) == 1 and point_region[-1] != 1


def test_a_stack_at_a_shelfs_end_seen_only_on_the_shelf_under_it_is_stored_a_piece_of_the_cases_colour_is_not():
    # a bookcase's shelf at 0.9 m, seen only up to x = 0.45 (its front edge too): a stack at x 0.55-0.75 hides
    # its end, which the shelf at 0.5 under it shows to reach x = 0.8; the next board over the stack at 1.3
    wood, blue = (0.58, 0.47, 0.37), (0.2, 0.3, 0.6)
    case = [_up((0.0, 0.0, 0.5), (0.8, 0.3, 0.5)), _up((0.0, 0.0, 0.9), (0.45, 0.3, 0.9))]
    case += [_faces((0.0, 0.0, 1.3), (0.8, 0.3, 1.3), (0, 0, -1))]
    case += [_side((x, 0.0, 0.925), (x, 0.3, 1.275)) for x in (0.0, 0.8)]
    stack = [_up((0.55, 0.025, 1.0), (0.75, 0.25, 1.0)), _faces((0.55, 0.275, 0.925), (0.75, 0.275, 0.975), (0, 1, 0))]
    stack += [_side((x, 0.025, 0.925), (x, 0.25, 0.975)) for x in (0.525, 0.775)]
    n_case = sum(len(f[0]) for f in case)
    for colour, stored in ((blue, True), (wood, False)):
        point_region, split = _split(case + stack, [wood] * len(case) + [colour] * len(stack))
        assert (point_region[:n_case] == 1).all()
        if stored:  # a stack of books: its centre lies over the case's shelves, under the shelf at 0.5
            assert split == 1 and len(np.unique(point_region[n_case:])) == 1 and point_region[-1] != 1
        else:  # of the case's colour at the end of a shelf it hides: a piece of the case
            assert split == 0 and (point_region == 1).all()


def test_a_stack_on_a_shelf_seen_only_along_its_front_edge_is_split_off_the_case_frame_above_it():
    # a bookcase's shelf at 1.3 m (at the cameras' height) seen only along its front edge, y 0.2-0.3 of its
    # 0.3 m depth, the shelf at 0.9 under it seen whole: a stack at x 0.5-0.7 stands on the hidden part, its
    # centre behind all that is seen of its shelf; the next board over it at 1.7 m and the case's sides hold it
    wood, blue = (0.58, 0.47, 0.37), (0.2, 0.3, 0.6)
    edge = _up((0.0, 0.2, 1.3), (0.8, 0.3, 1.3))
    hidden = (edge[0][:, 0] > 0.46) & (edge[0][:, 0] < 0.74) & (edge[0][:, 1] < 0.24)  # under the stack's front
    case = [_up((0.0, 0.0, 0.9), (0.8, 0.3, 0.9)), (edge[0][~hidden], edge[1][~hidden])]
    case += [_faces((0.0, 0.0, 1.7), (0.8, 0.3, 1.7), (0, 0, -1))]
    case += [_side((x, 0.0, 1.325), (x, 0.3, 1.675)) for x in (0.0, 0.8)]
    stack = [_up((0.5, 0.025, 1.45), (0.7, 0.2, 1.45)), _faces((0.5, 0.225, 1.325), (0.7, 0.225, 1.425), (0, 1, 0))]
    stack += [_side((x, 0.025, 1.325), (x, 0.2, 1.425)) for x in (0.475, 0.725)]
    point_region, split = _split(case + stack, [wood] * len(case) + [blue] * len(stack))
    n_case = sum(len(f[0]) for f in case)
    assert split == 1
    assert (point_region[:n_case] == 1).all()
    assert len(np.unique(point_region[n_case:])) == 1 and point_region[-1] != 1


def test_a_body_split_off_a_top_is_searched_for_bodies_on_its_own_tops():
    # a low table 1.6 by 0.8 m, its top at 0.45 m, and a hutch standing on it, 1 by 0.6 m, with a shelf at 0.8 m
    # and its top board at 1.225 m; a box stands on the hutch's shelf. The hutch is a body on the table's top
    # and the box one on the hutch's shelf
    top = _up((0.0, 0.0, 0.45), (1.6, 0.8, 0.45))
    under = (top[0][:, 0] > 0.29) & (top[0][:, 0] < 1.31) & (top[0][:, 1] > 0.09) & (top[0][:, 1] < 0.71)
    table = [(top[0][~under], top[1][~under])]
    table += [_side((x, y, 0.05), (x + 0.05, y + 0.05, 0.425)) for x in (0.0, 1.55) for y in (0.0, 0.75)]
    hutch = [_side((x, 0.1, 0.475), (x, 0.7, 1.2)) for x in (0.3, 1.3)]
    hutch += [_up((0.325, 0.1, 0.8), (1.275, 0.7, 0.8)), _up((0.3, 0.1, 1.225), (1.3, 0.7, 1.225))]
    box = [_up((0.6, 0.25, 1.0), (0.9, 0.5, 1.0))]
    box += [_side((x, 0.25, 0.825), (x, 0.5, 0.975)) for x in (0.575, 0.925)]
    point_region, split = _split(table + hutch + box)
    n_table, n_hutch = sum(len(f[0]) for f in table), sum(len(f[0]) for f in hutch)
    on_hutch, on_box = point_region[n_table : n_table + n_hutch], point_region[n_table + n_hutch :]
    assert split == 2
    assert (point_region[:n_table] == 1).all()
    assert len(np.unique(on_hutch)) == 1 and len(np.unique(on_box)) == 1
    assert len({1, int(on_hutch[0]), int(on_box[0])}) == 3


def test_a_board_covers_what_is_stored_under_it_a_picture_over_a_headboard_does_not():
    from rescene_core.segment.geometric.support import _board_share

    lo, hi = np.array([0.5, 0.0, 0.9]), np.array([0.7, 0.25, 1.0])  # a book stack on a shelf
    board = _box((0.0, 0.0, 1.3), (0.8, 0.3, 1.3))
    assert _board_share(board, lo, hi, CFG) == 1.0
    lip = _box((0.0, 0.225, 1.28), (0.8, 0.25, 1.3))  # the board over it seen along its front edge only
    assert CFG.stored_board_share <= _board_share(lip, lo, hi, CFG) < 0.5
    assert _board_share(board, lo, hi + [0.0, 0.0, 0.3], CFG) == 0.0  # the board 0.5 m over it is too far
    # a bed's headboard and pillows, 1.8 m wide, and a picture 60 cm wide hung on the wall over them
    bed_lo, bed_hi = np.array([0.0, 0.0, 0.5]), np.array([1.8, 0.5, 0.9])
    picture = _box((0.6, 0.0, 1.2), (1.2, 0.025, 1.35))
    assert _board_share(picture, bed_lo, bed_hi, CFG) < CFG.stored_board_share


def _ring(r: float, z: float, normal_z: float = 0.0, cx: float = 0.1, cy: float = 0.1):
    """Points [n, 3] about a circle of radius ``r`` (m) at height ``z``, one per STEP of its length, and
    their outward normals [n, 3] tilted by ``normal_z`` up."""
    a = np.linspace(0.0, 2 * np.pi, max(int(2 * np.pi * r / STEP), 6), endpoint=False)
    p = np.stack([cx + r * np.cos(a), cy + r * np.sin(a), np.full(len(a), z)], 1)
    n = np.stack([np.cos(a), np.sin(a), np.full(len(a), normal_z)], 1)
    return p, n / np.linalg.norm(n, axis=1, keepdims=True)


def _stacked(faces: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, int]:
    """The points [n, 3], and the region of each after ``split_stacked`` on one region holding all ``faces``."""
    from rescene_core.segment.geometric.stacks import split_stacked

    sp = _surfaces(faces)
    region = np.ones(sp.graph.size, np.int64)
    sp2, region2, _, split = split_stacked(sp, region, np.zeros(sp.graph.size, np.int64), CFG)
    return sp.points, region2[sp2.graph.label], split


def test_a_stack_on_a_stack_is_split_at_its_step_a_lamps_shade_or_a_plants_crown_is_not():
    # a stack 25 cm square and 10 cm tall on a desk (its foot at 0.75 m), seen from the front and the right,
    # with a stack 15 cm square on it: the ring of the lower one's top it leaves is 5 cm wide
    lower = [
        _faces((0.0, 0.0, 0.75), (0.25, 0.0, 0.825), (0, -1, 0)),
        _faces((0.25, 0.0, 0.75), (0.25, 0.25, 0.825), (1, 0, 0)),
    ]
    top = _up((0.0, 0.0, 0.85), (0.25, 0.25, 0.85))
    ring = ~np.all((top[0][:, :2] > 0.04) & (top[0][:, :2] < 0.21), axis=1)
    lower.append((top[0][ring], top[1][ring]))
    upper = [
        _faces((0.05, 0.05, 0.875), (0.2, 0.05, 0.95), (0, -1, 0)),
        _faces((0.2, 0.05, 0.875), (0.2, 0.2, 0.95), (1, 0, 0)),
        _up((0.05, 0.05, 0.975), (0.2, 0.2, 0.975)),
    ]
    stack = lower + upper
    p, region, split = _stacked(stack)
    n_lower = sum(len(f[0]) for f in lower)
    assert split == 1
    assert len(np.unique(region[:n_lower])) == 1 and len(np.unique(region[n_lower:])) == 1
    assert region[0] != region[-1]

    # a stack 21 cm square on it steps in by 0.84 and is split too; one 23 cm square, 0.92, is a book of the
    # same stack (a stack's books are 0.8-1.0 as wide as its widest)
    for side, apart in ((0.21, True), (0.23, False)):
        a, b = 0.125 - side / 2, 0.125 + side / 2
        ring = ~np.all((top[0][:, :2] > a - 0.01) & (top[0][:, :2] < b + 0.01), axis=1)
        upper = [
            _faces((a, a, 0.875), (b, a, 0.95), (0, -1, 0)),
            _faces((b, a, 0.875), (b, b, 0.95), (1, 0, 0)),
            _up((a, a, 0.975), (b, b, 0.975)),
        ]
        _, _, split = _stacked([*lower[:2], (top[0][ring], top[1][ring]), *upper])
        assert split == int(apart), side

    # a table lamp: a base disc, a stem, and a shade 30 cm wide at its foot narrowing to 20 cm at its top
    lamp = [_ring(0.08, 0.75 + k * STEP) for k in range(2)] + [_ring(0.01, 0.8 + k * STEP) for k in range(6)]
    lamp += [_ring(0.15 - 0.05 * k / 8, 0.95 + k * STEP, 0.25) for k in range(9)]
    _, region, split = _stacked(lamp)
    assert split == 0 and (region == 1).all()

    # a potted plant on a table: foliage 30 cm across over a pot 12 cm across, its crown narrowing to 22 cm;
    # the cut at the crown would leave a lower body flaring out upward from its foot
    plant = [_ring(0.06, 0.75 + k * STEP) for k in range(4)] + [_ring(0.15, 0.85 + k * STEP) for k in range(5)]
    plant += [_ring(0.11, 0.975 + k * STEP, 0.5) for k in range(3)]
    _, region, split = _stacked(plant)
    assert split == 0 and (region == 1).all()

    # on the floor: the same stacks are split as on the desk, the same plant stays whole
    _, region, split = _stacked([(f[0] - [0.0, 0.0, 0.75], f[1]) for f in stack])
    assert split == 1 and region[0] != region[-1]
    _, region, split = _stacked([(f[0] - [0.0, 0.0, 0.75], f[1]) for f in plant])
    assert split == 0 and (region == 1).all()


def test_a_wall_shelfs_bracket_joins_the_board_holding_the_other_one_a_picture_under_it_does_not():
    from rescene_core.segment.geometric.walls import _join_brackets

    # a wall shelf on the wall y = 0: a board 0.8 m wide and 0.25 m deep at 1.3-1.35 m on two brackets 22 cm
    # deep and 10 cm tall; the board's region already holds the left bracket, so its lowest point is the
    # bracket's foot, not the board's underside
    board = [
        _faces((0.0, 0.025, 1.35), (0.8, 0.25, 1.35), (0, 0, 1)),
        _faces((0.0, 0.25, 1.3), (0.8, 0.25, 1.325), (0, 1, 0)),
        _faces((0.0, 0.025, 1.275), (0.8, 0.25, 1.275), (0, 0, -1)),
    ]
    left = [
        _faces((0.25, 0.025, 1.15), (0.25, 0.225, 1.25), (-1, 0, 0)),
        _faces((0.3, 0.025, 1.15), (0.3, 0.225, 1.25), (1, 0, 0)),
    ]
    right = [
        _faces((0.55, 0.025, 1.15), (0.55, 0.225, 1.25), (-1, 0, 0)),
        _faces((0.6, 0.025, 1.15), (0.6, 0.225, 1.25), (1, 0, 0)),
    ]
    # a picture 40 cm wide flat on the wall under the shelf, its top touching the board's underside
    picture = [_faces((0.1, 0.025, 0.9), (0.5, 0.025, 1.25), (0, 1, 0))]
    for hung, joins in ((right, True), (picture, False)):
        faces = board + left + hung
        sp = _surfaces(faces)
        n_board = len(board) + len(left)
        region = np.where(np.arange(sp.graph.size) < n_board, 1, 2)
        joined, count = _join_brackets(sp, region, CFG, WALL)
        assert count == int(joins)
        assert (joined[n_board:] == (1 if joins else 2)).all() and (joined[:n_board] == 1).all()


def test_a_case_side_rising_unbroken_from_its_shelf_is_its_frame_a_stack_under_the_next_board_is_not():
    from rescene_core.segment.geometric.cases import _frame_columns

    h = 0.5  # the shelf's top
    side = _box((0.0, 0.0, h + 0.02), (0.0, 0.3, h + 0.9))  # a side panel's inner face, on past the next board
    stack = _box((0.05, 0.05, h + 0.02), (0.25, 0.25, h + 0.2))  # a stack 20 cm tall ...
    board = _box((0.0, 0.0, h + 0.36), (0.6, 0.3, h + 0.36))  # ... under the next board, 16 cm clear of it
    tall = _box((0.4, 0.05, h + 0.02), (0.5, 0.15, h + 0.34))  # a body filling its column to the board
    back = _box((0.6, 0.0, h + 0.17), (0.8, 0.0, h + 0.9))  # a back panel seen only over what stands before it
    stub = _box((0.9, 0.1, h + 0.26), (0.95, 0.15, h + 0.3))  # a body's top just under the height tested
    points = np.concatenate([side, stack, board, tall, back, stub])
    kind = np.repeat(np.arange(6), [len(side), len(stack), len(board), len(tall), len(back), len(stub)])
    frame = _frame_columns(points, np.ones(len(points), bool), h, CFG)
    assert frame[kind == 0].all() and frame[kind == 4].all()
    assert not frame[kind == 1].any() and not frame[kind == 5].any()
    assert frame[kind == 3].all()  # rising past the rise, it is taken as the frame's: the rule's known limit
    only_stack = kind == 1
    assert not _frame_columns(points, only_stack, h, CFG).any()  # only the stuck points are looked at


def test_books_lying_flat_change_colour_across_horizontal_seams_books_standing_across_vertical_ones():
    from rescene_core.segment.geometric.cases import _in_layers, _in_rows

    rng = np.random.default_rng(2)
    colours = rng.uniform(0.1, 0.9, (12, 3))

    def books(flat: bool) -> ScanPoints:
        # the front face (y = 0) of 6 books 4 cm thick, 24 cm wide and 24 cm tall all told, each its own colour
        face = _box((0.0, 0.0, 0.0), (0.24, 0.0, 0.24))
        nrm = np.tile([0.0, -1.0, 0.0], (len(face), 1))
        col = colours[np.minimum((face[:, 2 if flat else 0] / 0.04).astype(int), 5)]
        edges = point_graph(face, STEP * 1.75)
        _, concave, step = edge_weights(face, nrm, col, edges, 1.0)
        label = np.zeros(len(face), np.int64)
        g = superpoint_graph(face, nrm, col, label, edges, concave, step)
        return ScanPoints(face, nrm, col, label, np.arange(len(face)), edges, concave, step, g)

    stack, row = books(flat=True), books(flat=False)
    assert _in_layers(stack, np.ones(len(stack.points), bool), CFG)
    assert not _in_layers(row, np.ones(len(row.points), bool), CFG)
    assert not _in_layers(stack, stack.points[:, 2] < 0.035, CFG)  # one book: no seams to count
    assert _in_rows(row, np.ones(len(row.points), bool), CFG)
    assert not _in_rows(stack, np.ones(len(stack.points), bool), CFG)
    assert not _in_rows(row, row.points[:, 0] < 0.035, CFG)  # one book standing: no seams to count either


def test_a_desk_joined_to_a_stretch_of_wall_the_plane_left_is_parted_from_it_a_bulge_of_the_wall_is_not():
    from rescene_core.segment.geometric.walls import part_from_wall_stretch

    def scan(wall_height: float) -> tuple[ScanPoints, np.ndarray]:
        # a stretch of the wall y = 0 fused 3 cm in front of its plane, a bulge of it 8 cm out, and a desk
        # (top and front, 0.65 m deep) standing against it, all one region
        stretch = _faces((0.0, 0.03, 0.0), (3.0, 0.03, wall_height), (0.0, 1.0, 0.0))
        bulge = _faces((2.5, 0.08, 1.2), (2.8, 0.08, 1.5), (0.0, 1.0, 0.0))
        top = _faces((1.0, 0.05, 0.75), (2.2, 0.7, 0.75), (0.0, 0.0, 1.0))
        front = _faces((1.0, 0.7, 0.0), (2.2, 0.7, 0.725), (0.0, 1.0, 0.0))
        sp = _surfaces([stretch, bulge, top, front])
        return sp, np.ones(sp.graph.size, np.int64)

    sp, region = scan(2.4)
    which = np.zeros(len(region), np.int64)
    sp2, region2, which2, parted = part_from_wall_stretch(sp, region, which, WALL, CFG)
    assert parted == 1
    point_region = region2[sp2.graph.label]
    desk = (sp2.points[:, 1] >= CFG.stands_out) & (sp2.points[:, 2] >= CFG.stands_out)
    assert len(np.unique(point_region[desk])) == 1 and point_region[desk][0] != 1
    assert (point_region[~desk] == 1).all()  # the stretch, its bulge and the desk's edge by the wall stay
    assert len(which2) == len(region2)
    # a region lower than a wall is no stretch of it: left whole (the sliver test judges it later)
    sp, region = scan(1.6)
    assert part_from_wall_stretch(sp, region, np.zeros(len(region), np.int64), WALL, CFG)[3] == 0


PAINT = np.array([0.8, 0.78, 0.75])


def _on_wall(parts: list[tuple[np.ndarray, object, int, int]]) -> ScanPoints:
    """ScanPoints of point sets [k, 3] facing +y, each with its colour (RGB, or [k, 3]), its wall (0: none,
    as ``ScanPoints.wall``) and its superpoint."""
    pts = np.concatenate([p for p, _, _, _ in parts])
    colours = np.concatenate([np.broadcast_to(np.asarray(c, float), (len(p), 3)) for p, c, _, _ in parts])
    on_wall = np.concatenate([np.full(len(p), w, np.int64) for p, _, w, _ in parts])
    label = np.concatenate([np.full(len(p), i, np.int64) for p, _, _, i in parts])
    nrm = np.tile([0.0, 1.0, 0.0], (len(pts), 1))
    edges = point_graph(pts, STEP * 1.75)
    _, concave, step = edge_weights(pts, nrm, colours, edges, 1.0)
    g = superpoint_graph(pts, nrm, colours, label, edges, concave, step)
    return ScanPoints(pts, nrm, colours, on_wall, np.arange(len(pts)), edges, concave, step, g)


def test_the_walls_paint_and_its_shadow_in_a_wall_shelfs_region_are_taken_off_a_picture_on_it_is_not():
    from rescene_core.segment.geometric.walls import take_off_wall_paint

    wall = _box((0.0, 0.0, 0.5), (2.0, 0.0, 2.0))  # the wall y = 0, its paint
    under = (wall[:, 0] >= 0.5) & (wall[:, 0] <= 1.3) & (wall[:, 2] >= 1.3) & (wall[:, 2] < 1.5)
    red = under & (wall[:, 0] > 1.1)  # a red card pinned under the board
    shadow = under & ~red  # the wall in the board's shadow: its paint darkened
    colours = np.where(shadow[:, None], 0.6 * PAINT, np.where(red[:, None], [0.8, 0.1, 0.1], PAINT))
    board = _box((0.5, 0.025, 1.5), (1.3, 0.25, 1.5))  # a wall shelf's board
    # the wall's superpoint in no region; the shadow's (with the card) fused with the board's region
    sp = _on_wall([(wall[~under], PAINT, 2, 0), (wall[under], colours[under], 2, 1), (board, [0.4, 0.3, 0.2], 0, 2)])
    sp2, region2, which2, taken = take_off_wall_paint(sp, np.array([0, 1, 1]), np.array([2, 0, 0]), WALL, CFG)
    point_region = region2[sp2.graph.label]
    is_shadow = np.r_[np.zeros((~under).sum(), bool), shadow[under], np.zeros(len(board), bool)]
    is_red = np.r_[np.zeros((~under).sum(), bool), red[under], np.zeros(len(board), bool)]
    assert taken == int(shadow.sum()) and (point_region[is_shadow] == 0).all()
    assert (point_region[is_red] == 1).all() and (point_region[-len(board) :] == 1).all()
    assert len(which2) == len(region2)
    # a region mostly on its wall (a picture) is left whole: the flush test judges it
    assert take_off_wall_paint(sp, np.array([0, 1, 0]), np.array([2, 0, 0]), WALL, CFG)[3] == 0
    # a region hung flat on the wall (a clock whose rim, 4 cm proud, outnumbers its face of the wall's
    # white) is left whole too
    face = _box((0.3, 0.01, 1.0), (0.4, 0.01, 1.1))
    rim = np.concatenate([_box((0.2, 0.04, 0.9), (0.5, 0.04, 0.95)), _box((0.2, 0.04, 1.15), (0.5, 0.04, 1.2))])
    sp = _on_wall([(wall, PAINT, 2, 0), (face, PAINT, 2, 1), (rim, [0.1, 0.1, 0.1], 0, 1)])
    assert take_off_wall_paint(sp, np.array([0, 1]), np.array([2, 2]), WALL, CFG)[3] == 0
    # and so is a sliver of the wall (a patch by the floor, half on the plane and half just off it, with a
    # scrap 15 cm out): the filter drops it whole, where without its paint it would no longer look a sliver
    patch = _box((3.0, 0.0, 0.05), (3.3, 0.0, 0.8))
    sp = _on_wall(
        [
            (patch, PAINT, 2, 0),
            (patch + [0.0, 0.02, 0.0], PAINT, 0, 1),
            (_box((3.0, 0.05, 0.05), (3.1, 0.15, 0.1)), PAINT, 0, 1),
        ]
    )
    assert take_off_wall_paint(sp, np.array([1, 1]), np.array([2, 0]), WALL, CFG)[3] == 0
