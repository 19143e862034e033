from __future__ import annotations

import pytest

from rescene_core.vqa import VqaScene
from tests.vqa.scenes import make_bedroom


@pytest.fixture
def bedroom() -> VqaScene:
    return make_bedroom()
