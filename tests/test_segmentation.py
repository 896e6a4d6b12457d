"""Grey-level images in the scene (aromm.microstructure.segmentation): thresholds, Otsu, crop, down-sampling.

Independent truths: the labels an image was drawn from; the misclassification rate of a threshold on Gaussian
noise (normal tail probabilities); block shapes by arithmetic.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import tifffile

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.microstructure.segmentation import Segmentation, save_histogram, segment
from aromm.scene.scene_file import load_scene

PHASES = """
[phases.gas]
label = 0
k = 0.025
[phases.fibre]
label = 1
k = 0.3
"""


def _labels(rng: np.random.Generator, shape: tuple[int, int, int] = (16, 16, 16)) -> np.ndarray:
    """Blocky two-phase labels: 2³ blocks drawn with P(1) = 0.3."""
    coarse = (rng.random(tuple(n // 2 for n in shape)) < 0.3).astype(np.int32)
    return np.repeat(np.repeat(np.repeat(coarse, 2, 0), 2, 1), 2, 2)


def _write_tiff(path: Path, grey: np.ndarray) -> Path:
    tifffile.imwrite(path, np.ascontiguousarray(grey.transpose(2, 1, 0)))  # pages are z slices of (y, x)
    return path


def _scene(folder: Path, geometry: str, phases: str = PHASES) -> Path:
    path = folder / "scene.toml"
    path.write_text(f"[geometry]\n{geometry}\nvoxel_size = 1.0e-5\n{phases}", encoding="utf-8")
    return path


@pytest.mark.parametrize("dtype,scale", [(np.uint8, 1.0), (np.uint16, 250.0), (np.float32, 1e-3)])
def test_thresholds_recover_the_labels_exactly_from_8_16_bit_and_float_tiffs(tmp_path: Path, dtype: type,
                                                                              scale: float) -> None:
    """Grey = (60 + 120 label ± 50) × scale: the classes do not overlap, threshold 120 × scale separates them."""
    rng = np.random.default_rng(1)
    truth = _labels(rng)
    grey = ((60.0 + 120.0 * truth + rng.uniform(-50.0, 50.0, truth.shape)) * scale).astype(dtype)
    _write_tiff(tmp_path / "grey.tif", grey)
    scene = load_scene(_scene(tmp_path, f'image = "grey.tif"\nsegment = {{ thresholds = [{120.0 * scale!r}] }}'))
    assert np.array_equal(scene.geometry.labels, truth)  # type: ignore[union-attr]
    report = scene.segmentation
    assert report is not None and report.thresholds == (120.0 * scale,) and report.dtype == np.dtype(dtype).name
    assert report.fractions == pytest.approx((1 - truth.mean(), truth.mean()), abs=0)
    assert scene.volume_fractions()["fibre"] == pytest.approx(truth.mean(), abs=0)
    assert int(report.counts.sum()) == truth.size


def _normal_tail(x: float) -> float:
    """P(N(0, 1) > x)."""
    return 0.5 * math.erfc(x / math.sqrt(2.0))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_otsu_on_a_noisy_bimodal_image_recovers_the_volume_fractions(seed: int) -> None:
    """Class means μ0 = 80, μ1 = 170, Gaussian noise σ = 15 (gap 6σ).  For the threshold t Otsu returns, the
    expected misclassified fraction is e = f0 P(N > (t − μ0)/σ) + f1 P(N > (μ1 − t)/σ); the labelled fraction
    of phase 1 must be within e + 5 √(e/N) of the truth (the count of misclassified voxels is binomial)."""
    rng = np.random.default_rng(seed)
    truth = _labels(rng, (24, 24, 24))
    mu0, mu1, sigma = 80.0, 170.0, 15.0
    grey = np.clip(np.where(truth == 1, mu1, mu0) + rng.normal(0.0, sigma, truth.shape), 0, 255).astype(np.uint8)
    labels, report = segment(grey, Segmentation("otsu"))
    (t,) = report.thresholds
    assert abs(t - 0.5 * (mu0 + mu1)) < sigma  # the threshold falls in the gap
    f1 = float(truth.mean())
    e = (1 - f1) * _normal_tail((t - mu0) / sigma) + f1 * _normal_tail((mu1 - t) / sigma)
    tolerance = e + 5.0 * math.sqrt(e / truth.size) + 1.0 / truth.size
    assert abs(report.fractions[1] - f1) <= tolerance
    assert abs(float(labels.mean()) - f1) <= tolerance


def test_median_denoising_removes_most_misclassified_voxels() -> None:
    """Gap 3σ: about 6.7 % of voxels fall across the threshold; after a 3³ median almost none do away from the
    interfaces (14 of 27 neighbours would have to cross at once)."""
    rng = np.random.default_rng(3)
    truth = np.zeros((24, 24, 24), dtype=np.int32)
    truth[12:] = 1
    grey = (np.where(truth == 1, 145.0, 100.0) + rng.normal(0.0, 15.0, truth.shape)).astype(np.float32)
    raw, _ = segment(grey, Segmentation("thresholds", (122.5,)))
    smooth, report = segment(grey, Segmentation("thresholds", (122.5,), denoise="median", size=3))
    raw_errors, smooth_errors = int((raw != truth).sum()), int((smooth != truth).sum())
    assert raw_errors > 0.04 * truth.size
    assert smooth_errors < raw_errors / 20
    assert report.denoise == "median"
    gaussian, _ = segment(grey, Segmentation("thresholds", (122.5,), denoise="gaussian", sigma=1.0))
    assert int((gaussian != truth).sum()) < raw_errors / 5


def test_multiotsu_separates_three_phases(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    truth = rng.integers(0, 3, (16, 16, 16)).astype(np.int32)
    grey = (40 + 80 * truth + rng.integers(-10, 10, truth.shape)).astype(np.uint8)
    labels, report = segment(grey, Segmentation("multiotsu", classes=3))
    assert np.array_equal(labels, truth)
    assert len(report.thresholds) == 2
    assert report.fractions == pytest.approx(tuple(np.bincount(truth.ravel()) / truth.size), abs=0)
    png = save_histogram(report, tmp_path / "histogram.png")
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_crop_and_downsample_shapes_and_voxel_size(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    truth = _labels(rng, (16, 16, 16))
    np.save(tmp_path / "labels.npy", truth)
    grey = (60 + 120 * truth).astype(np.uint8)
    _write_tiff(tmp_path / "grey.tif", grey)
    cropped = load_scene(_scene(tmp_path, 'image = "labels.npy"\ncrop = [[2, 10], [0, 16], [4, 12]]'))
    assert cropped.geometry.shape == (8, 16, 8)  # type: ignore[union-attr]
    assert np.array_equal(cropped.geometry.labels, truth[2:10, :, 4:12])  # type: ignore[union-attr]
    coarse = load_scene(_scene(tmp_path, 'image = "labels.npy"\ndownsample = 2'))
    assert coarse.geometry.shape == (8, 8, 8) and coarse.geometry.voxel_size == (2e-5,) * 3  # type: ignore[union-attr]
    assert np.array_equal(coarse.geometry.labels, truth[::2, ::2, ::2])  # 2³ blocks hold one label each
    both = load_scene(_scene(tmp_path, 'image = "grey.tif"\ncrop = [[0, 15], [1, 16], [0, 16]]\ndownsample = 2\n'
                                       'segment = { method = "otsu" }'))
    assert both.geometry.shape == (7, 7, 8)  # type: ignore[union-attr]  # partial blocks dropped
    assert both.segmentation is not None and both.segmentation.shape == (7, 7, 8)


@pytest.mark.parametrize(("geometry", "key"), [
    ('image = "grey.tif"', "geometry.image"),  # a grey image without segment
    ('image = "grey.tif"\nsegment = { method = "kmeans" }', "geometry.segment.method"),
    ('image = "grey.tif"\nsegment = { thresholds = [150, 100] }', "geometry.segment.thresholds"),
    ('image = "grey.tif"\nsegment = { method = "otsu", classes = 3 }', "geometry.segment.classes"),
    ('image = "grey.tif"\nsegment = { method = "otsu", level = 3 }', "geometry.segment.level"),
    ('image = "grey.tif"\nsegment = { method = "otsu", sigma = 1.0 }', "geometry.segment.sigma"),
    ('image = "grey.tif"\nsegment = { method = "otsu", denoise = "bilateral" }', "geometry.segment.denoise"),
    ('image = "grey.tif"\nsegment = "otsu"', "geometry.segment"),
    ('image = "grey.tif"\ncrop = [[0, 17], [0, 16], [0, 16]]\nsegment = { method = "otsu" }', "geometry.crop"),
    ('image = "grey.tif"\ncrop = [0, 8]\nsegment = { method = "otsu" }', "geometry.crop"),
    ('image = "grey.tif"\ndownsample = 0\nsegment = { method = "otsu" }', "geometry.downsample"),
    ('image = "grey.tif"\nthreshold = 3', "geometry.threshold"),
])
def test_bad_keys_are_refused_naming_the_key(tmp_path: Path, geometry: str, key: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    grey = (np.arange(16**3).reshape(16, 16, 16) % 200 + 0.5).astype(np.float32)
    _write_tiff(tmp_path / "grey.tif", grey)
    path = _scene(tmp_path, geometry)
    with pytest.raises(InputError, match=f"{key}:"):
        load_scene(path)
    assert main(["segment", str(path)]) == 2
    assert key in capsys.readouterr().err


def test_segment_command_prints_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    truth = _labels(np.random.default_rng(6))
    _write_tiff(tmp_path / "grey.tif", (60 + 120 * truth).astype(np.uint16))
    path = _scene(tmp_path, 'image = "grey.tif"\nsegment = { method = "otsu" }')
    assert main(["segment", str(path), "--json", "--plot", str(tmp_path / "h.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "otsu" and 60 <= out["thresholds"][0] < 180
    assert out["phases"]["fibre"] == pytest.approx(truth.mean(), abs=0)
    assert (tmp_path / "h.png").is_file()
    assert main(["segment", str(path)]) == 0
    assert "volume fraction" in capsys.readouterr().out
