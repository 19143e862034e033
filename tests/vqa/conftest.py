from __future__ import annotations

import pytest

from rescene_core.vqa import VqaScene
from tests.vqa.scenes import make_bedroom


@pytest.fixture
def bedroom() -> VqaScene:
    return make_bedroom()


SMALL_CONFIG = dict(
    sampling="walk", walk_steps=6, per_category=8, image_width=64, image_height=48, min_visible_pixels=8
)
"""A small walk configuration that keeps data-set tests fast."""


@pytest.fixture(scope="session")
def small_ds(tmp_path_factory):
    """A data set over four tiny synthetic layouts (three train, one test) and a source that fails."""
    from rescene_core.vqa import VqaConfig
    from rescene_core.vqa.build import build_dataset, scene_source

    out = tmp_path_factory.mktemp("vqa_ds") / "ds"
    sources = [scene_source(f"synth:tiny:{s}") for s in range(4)] + [scene_source(out.parent / "no-such-run")]
    calls = []
    card = build_dataset(sources, out, VqaConfig(**SMALL_CONFIG), test_ratio=0.25, progress=lambda *a: calls.append(a))
    return out, card, calls
