"""Generated assets in the user cache (rescene_core/assets/cache.py): a second generation of the same view
loads the first one's asset, another view or other settings generate again, a corrupt entry is generated
and written again, and a backend passed in is always run."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from rescene_core.assets import cache as asset_cache
from rescene_core.assets import generate_asset
from rescene_core.assets.lift import LiftBackend
from rescene_core.config import AssetConfig
from rescene_core.records import Asset, InstanceId, ViewChoice
from tests.assets.test_assets import look_at_camera, render_view


@pytest.fixture(scope="module")
def cabinet_capture():
    cabinet = trimesh.creation.box(bounds=[[-0.3, -0.2, 0.0], [0.3, 0.2, 0.8]])
    full = render_view(cabinet, look_at_camera(np.array([1.6, 2.2, 1.4]), np.array([0.0, 0.0, 0.45])))

    class Cap:  # the Capture surface generate_asset reads
        num_frames = 1
        rgb = full.rgb[None]
        instance_masks = np.where(full.mask, 5, 0)[None]
        depth = full.depth[None]

        def instance(self, i):
            raise KeyError(i)

        def camera(self, t):
            return full.camera

    return Cap()


@pytest.fixture
def lift_calls(tmp_path, monkeypatch):
    monkeypatch.setenv("RESCENE_CACHE_DIR", str(tmp_path / "usercache"))
    calls: list[int] = []
    real = LiftBackend.generate

    def counting(self, view):
        calls.append(int(view.instance))
        return real(self, view)

    monkeypatch.setattr(LiftBackend, "generate", counting)
    return calls


VIEW = ViewChoice(InstanceId(5), 0, "test", "test")


def _same(a: Asset, b: Asset) -> bool:
    return (
        np.array_equal(a.vertices, b.vertices)
        and np.array_equal(a.faces, b.faces)
        and np.array_equal(a.asset_from_generator, b.asset_from_generator)
        and a.metadata == b.metadata
        and a.backend == b.backend
    )


def test_the_same_view_is_generated_once(cabinet_capture, lift_calls, tmp_path):
    first = generate_asset(cabinet_capture, VIEW, AssetConfig())
    second = generate_asset(cabinet_capture, VIEW, AssetConfig())
    assert isinstance(first, Asset) and isinstance(second, Asset)
    assert lift_calls == [5]
    assert _same(first, second) and second.metadata["view_method"] == "test"
    assert len(list((tmp_path / "usercache" / "assets").rglob("*.npz"))) == 1
    finer = AssetConfig.model_validate({"lift": {"resolution": AssetConfig().lift.resolution + 8}})
    assert isinstance(generate_asset(cabinet_capture, VIEW, finer), Asset)
    assert lift_calls == [5, 5]  # other settings: generated again


def test_a_corrupt_entry_is_generated_and_written_again(cabinet_capture, lift_calls, tmp_path):
    first = generate_asset(cabinet_capture, VIEW, AssetConfig())
    (entry,) = (tmp_path / "usercache" / "assets").rglob("*.npz")
    entry.write_bytes(b"not an npz")
    again = generate_asset(cabinet_capture, VIEW, AssetConfig())
    assert lift_calls == [5, 5] and isinstance(first, Asset) and isinstance(again, Asset) and _same(first, again)
    assert asset_cache.decode(entry.read_bytes(), InstanceId(5)) is not None


def test_a_backend_passed_in_is_always_run(cabinet_capture, lift_calls):
    backend = LiftBackend(AssetConfig())
    generate_asset(cabinet_capture, VIEW, AssetConfig(), backend=backend)
    generate_asset(cabinet_capture, VIEW, AssetConfig(), backend=backend)
    assert lift_calls == [5, 5]
