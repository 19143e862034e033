"""torch and open_clip are the `clip` extra: the library imports without them and names the extra when needed."""

import subprocess
import sys

import pytest

from rescene_core.hierview import semantic

HEAVY = ("torch", "torchvision", "open_clip", "lpips", "vllm")


@pytest.mark.slow
def test_no_module_of_the_library_imports_torch_on_import():
    """Every rescene_core module in a fresh interpreter (about 10-30 s: Open3D, MuJoCo, USD load)."""
    code = (
        "import importlib, pkgutil, sys\n"
        "import rescene_core\n"
        "for m in pkgutil.walk_packages(rescene_core.__path__, 'rescene_core.'):\n"
        "    importlib.import_module(m.name)\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_clip_backend_names_the_extra_when_open_clip_is_missing(monkeypatch):
    monkeypatch.setitem(sys.modules, "open_clip", None)  # import open_clip -> ImportError
    with pytest.raises(semantic.ClipUnavailableError, match=r"pip install 'rescene\[clip\]'"):
        semantic._load_clip.__wrapped__("ViT-B-32", "/nowhere/weights.pt", 0.0)
