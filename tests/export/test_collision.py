"""Exact convex pieces before CoACD: convex components keep their hull, unions of axis-aligned boxes are
cut into their boxes, and only the rest goes to CoACD."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.colliders.decompose import DecompositionSettings, box_pieces, decompose


def _box(lo, hi) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=np.array([lo, hi], np.float64))


def _bounds(piece) -> np.ndarray:
    v, _ = piece
    return np.round(np.stack([v.min(0), v.max(0)]), 9)


def _inside_any(dec, point) -> bool:
    return any(trimesh.Trimesh(v, f, process=False).contains([point])[0] for v, f in dec.pieces)


def shelf_mesh() -> trimesh.Trimesh:
    """A bookshelf 0.8 x 0.3 x 1.2: two sides, back, bottom, top and two inner boards, as one solid."""
    w, d, h, t = 0.8, 0.3, 1.2, 0.02
    parts = [
        _box([-w / 2, -d / 2, 0], [-w / 2 + t, d / 2, h]),
        _box([w / 2 - t, -d / 2, 0], [w / 2, d / 2, h]),
        _box([-w / 2, -d / 2, 0], [w / 2, -d / 2 + t, h]),
        _box([-w / 2, -d / 2, 0], [w / 2, d / 2, 0.05]),
        _box([-w / 2, -d / 2, h - t], [w / 2, d / 2, h]),
        _box([-w / 2, -d / 2, 0.4 - t], [w / 2, d / 2, 0.4]),
        _box([-w / 2, -d / 2, 0.8 - t], [w / 2, d / 2, 0.8]),
    ]
    return trimesh.boolean.union(parts, engine="manifold")


def test_two_separate_boxes_are_exactly_two_pieces(tmp_path):
    a, b = _box([0, 0, 0], [0.4, 0.3, 0.2]), _box([1, 0, 0], [1.2, 0.5, 0.6])
    both = trimesh.util.concatenate([a, b])
    dec = decompose(both.vertices, both.faces, DecompositionSettings(cache_dir=str(tmp_path)))
    assert dec.method == "components" and len(dec.pieces) == 2
    got = sorted(_bounds(p).tolist() for p in dec.pieces)
    assert got == sorted([a.bounds.tolist(), b.bounds.tolist()])
    assert dec.volume == pytest.approx(a.volume + b.volume, rel=1e-9)
    assert not list(tmp_path.iterdir())  # no CoACD ran, nothing cached


def test_a_union_of_overlapping_boxes_is_cut_exactly():
    ell = trimesh.boolean.union([_box([0, 0, 0], [1, 0.2, 0.1]), _box([0, 0, 0], [0.2, 1, 0.1])], engine="manifold")
    pieces = box_pieces(ell.vertices, ell.faces)
    assert pieces is not None and len(pieces) == 2
    assert sum(trimesh.Trimesh(v, f).volume for v, f in pieces) == pytest.approx(
        ell.volume, rel=1e-6
    )  # manifold3d works in float32


def test_shelf_compartments_stay_free(tmp_path):
    shelf = shelf_mesh()
    dec = decompose(shelf.vertices, shelf.faces, DecompositionSettings(cache_dir=str(tmp_path)))
    assert dec.method == "components"
    assert dec.volume == pytest.approx(shelf.volume, rel=1e-6)
    for z in (0.2, 0.6, 1.0):  # the middle of each compartment, and a point just above each board
        assert not _inside_any(dec, [0.0, 0.05, z])
    for z in (0.051, 0.401, 0.801):
        assert not _inside_any(dec, [0.3, 0.1, z])
    assert _inside_any(dec, [0.0, 0.0, 0.39])  # inside a board


def test_a_slanted_solid_is_not_cut_into_boxes():
    shelf = shelf_mesh()
    shelf.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
    assert box_pieces(shelf.vertices, shelf.faces) is None


def test_a_convex_component_keeps_its_hull_and_a_concave_one_goes_to_coacd(tmp_path):
    cup = trimesh.creation.cylinder(radius=0.05, height=0.1, sections=16)
    ell = trimesh.boolean.union([_box([0, 0, 0], [1, 0.2, 0.1]), _box([0, 0, 0], [0.2, 1, 0.1])], engine="manifold")
    ell.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
    ell.apply_translation([2, 0, 0])
    both = trimesh.util.concatenate([cup, ell])
    dec = decompose(both.vertices, both.faces, DecompositionSettings(cache_dir=str(tmp_path)))
    assert dec.method == "coacd" and any("exact pieces of 1 of 2 components" in n for n in dec.notes)
    cup_pieces = [p for p in dec.pieces if p[0][:, 0].max() < 1.0]
    assert len(cup_pieces) == 1 and trimesh.Trimesh(*cup_pieces[0]).volume == pytest.approx(cup.volume, rel=1e-6)
    assert len(list(tmp_path.rglob("*.npz"))) == 1  # the concave rest in one CoACD call


def test_components_none_exact_go_to_coacd_once_as_one_mesh(tmp_path):
    def slanted_ell(x):
        ell = trimesh.boolean.union([_box([0, 0, 0], [1, 0.2, 0.1]), _box([0, 0, 0], [0.2, 1, 0.1])], engine="manifold")
        ell.apply_transform(trimesh.transformations.rotation_matrix(np.radians(30), [0, 0, 1]))
        ell.apply_translation([x, 0, 0])
        return ell

    both = trimesh.util.concatenate([slanted_ell(0.0), slanted_ell(2.0)])
    settings = DecompositionSettings(max_pieces=4, cache_dir=str(tmp_path))
    dec = decompose(both.vertices, both.faces, settings)
    assert dec.method == "coacd" and not any("exact pieces" in n for n in dec.notes)
    assert len(list(tmp_path.rglob("*.npz"))) == 1  # one CoACD call on the whole mesh
    assert len(dec.pieces) <= 4


def _cup(radius: float, height: float) -> trimesh.Trimesh:
    """A cup: a cylinder hollowed from the top to a bottom a tenth of its height thick (concave)."""
    outer = trimesh.creation.cylinder(radius=radius, height=height, sections=32)
    inner = trimesh.creation.cylinder(radius=0.8 * radius, height=height, sections=32)
    inner.apply_translation([0.0, 0.0, 0.1 * height])
    return trimesh.boolean.difference([outer, inner], engine="manifold")


def test_a_small_cup_gets_its_hull_and_no_coacd(tmp_path):
    cup = _cup(0.04, 0.09)
    assert cup.volume < 0.9 * cup.convex_hull.volume  # concave: CoACD would cut it
    dec = decompose(cup.vertices, cup.faces, DecompositionSettings(cache_dir=str(tmp_path)))
    assert dec.method == "hull" and len(dec.pieces) == 1
    assert any("small object" in n for n in dec.notes)
    assert trimesh.Trimesh(*dec.pieces[0]).volume == pytest.approx(cup.convex_hull.volume, rel=1e-6)
    assert not list(tmp_path.rglob("*.npz"))  # no CoACD ran
    # the same cup 0.5 m across is above the threshold: CoACD cuts it
    big = _cup(0.25, 0.5)
    settings = DecompositionSettings(max_pieces=4, cache_dir=str(tmp_path))
    assert decompose(big.vertices, big.faces, settings).method == "coacd"
    assert len(list(tmp_path.rglob("*.npz"))) == 1
