"""The whole evaluation of a run directory: perfect runs score perfectly, broken runs say what is missing."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from rescene_core.evaluation import evaluate_run
from rescene_core.evaluation.geometry import GeometryConfig
from rescene_core.evaluation.rendering import RenderingConfig, psnr, ssim
from rescene_core.evaluation.run import EvaluationConfig
from tests.evaluation.scene import write_test_capture, write_test_run

NO_HTML = EvaluationConfig(html=False, rendering=RenderingConfig(scale=1.0), geometry=GeometryConfig(fuse_scale=1.0))


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    return write_test_capture(tmp_path_factory.mktemp("cap") / "room.zarr")


def test_image_against_itself():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (40, 50, 3), dtype=np.uint8)
    assert psnr(img, img, cap=100.0) == 100.0
    full, masked = ssim(img, img, np.ones((40, 50), bool))
    assert full == pytest.approx(1.0) and masked == pytest.approx(1.0)


def test_ssim_is_scikit_image_and_psnr_the_formula():
    from skimage.metrics import structural_similarity

    rng = np.random.default_rng(1)
    a = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    b = np.clip(a.astype(int) + rng.integers(-20, 20, a.shape), 0, 255).astype(np.uint8)
    ref = structural_similarity(
        a, b, channel_axis=2, gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=255
    )
    assert ssim(a, b)[0] == pytest.approx(ref, abs=1e-12)
    mse = np.mean((a.astype(float) - b.astype(float)) ** 2)
    assert psnr(a, b) == pytest.approx(10 * np.log10(255**2 / mse))


def test_true_layout_scores_perfectly(capture, tmp_path):
    run = write_test_run(tmp_path / "run", capture)
    m = evaluate_run(run, config=NO_HTML)
    r = m["rendering"]
    assert r["frames"] == [1, 2, 3, 5, 6, 7]  # key frames 0 and 4 left out
    assert r["depth"]["abs_rel"] == pytest.approx(0.0, abs=1e-4) and r["depth"]["delta_1.25"] == 1.0
    assert r["mask_iou_mean_placed"] > 0.97
    assert r["psnr_masked"] > 40 and r["ssim_masked"] > 0.97
    g = m["geometry"]
    assert g["ground_truth"]["sampled"]["chamfer"] == pytest.approx(0.0, abs=1e-6)
    assert g["ground_truth"]["sampled"]["fscore@5cm"] == 1.0
    assert g["ground_truth"]["refused"]["fscore@5cm"] > 0.99
    assert g["sensor"]["objects_refused"]["fscore@5cm"] > 0.97
    assert all(row["sampled"]["chamfer"] == pytest.approx(0.0, abs=1e-6) for row in g["ground_truth"]["per_object"])
    assert m["judge"]["status"] == "off" and "judge" in m["not_computed"]
    assert m["not_computed"]["physics"].startswith("no sim/simcheck.json")
    assert m["summary"]["geometry_ground_truth_sampled_fscore@5cm"] == 1.0


def test_shifted_layout_scores_worse(capture, tmp_path):
    good = evaluate_run(write_test_run(tmp_path / "good", capture), config=NO_HTML)
    bad = evaluate_run(write_test_run(tmp_path / "bad", capture, shift=0.15), config=NO_HTML)
    for key in ("sampled", "refused"):
        assert bad["geometry"]["ground_truth"][key]["chamfer"] > good["geometry"]["ground_truth"][key]["chamfer"] + 0.02
    assert bad["rendering"]["mask_iou_mean_placed"] < good["rendering"]["mask_iou_mean_placed"] - 0.1
    assert bad["rendering"]["depth"]["abs_rel"] > 0.01


def test_missing_pieces_are_listed_not_fatal(capture, tmp_path):
    nodepth = write_test_capture(tmp_path / "nodepth.zarr", depth=False)
    run = write_test_run(tmp_path / "run", nodepth, keyframes=False)
    m = evaluate_run(run, config=NO_HTML)
    assert "sensor" not in m["geometry"] and "frames/depth" in m["not_computed"]["geometry.sensor"]
    assert "depth" not in m["rendering"] and "rendering.depth" in m["not_computed"]
    assert m["rendering"]["frames"] == list(range(8)) and "key_frames" in m["not_computed"]
    assert m["geometry"]["ground_truth"]["sampled"]["fscore@5cm"] == 1.0
    # the capture disappears: structure is still measured, the rest says why not
    shutil.rmtree(nodepth)
    m = evaluate_run(run, config=NO_HTML)
    assert m["structural"]["object_count"] == 2
    for key in ("geometry", "rendering", "ground_truth"):
        assert "does not exist" in m["not_computed"][key]
    # no exported scene and no capture: a clear error
    shutil.rmtree(run / "scene")
    with pytest.raises(FileNotFoundError, match="nothing to evaluate"):
        evaluate_run(run, config=NO_HTML)
