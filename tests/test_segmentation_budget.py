"""The segmentation row of the error budget (``identify --segmentation-check``): data of the image thresholded one
way, a model of the image thresholded another.

Truth: the parameters that made the data, on the grey image thresholded by Li's method [Li1993].  The model of the
same image thresholded by Otsu's [Otsu1979] (9 % more gas here) fits them with a biased conductivity whose noise-only
interval misses the truth; re-fitted with the other threshold's model, the shift enters the budget and the total
interval covers the truth again.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_text import scenario_1_text
from scipy import ndimage

from aromm.cli import main
from aromm.cli.checks import other_segmentation
from aromm.full.solve import FullModel
from aromm.scene.scene_file import assemble, load_scene
from inverse.identification import identify
from inverse.measurements import save_measurements, simulate_measurements

TRUTH = {"fibre.k": 0.3, "fibre.c": 4e6}
UNKNOWNS = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}


def grey_scene(folder: Path, segment: str = 'segment = { method = "otsu" }') -> Path:
    """An 8³ grey scan of a random two-phase medium: labels blurred (partial volume) plus noise, 8-bit."""
    rng = np.random.default_rng(3)
    labels = (rng.random((8, 8, 8)) < 0.35).astype(float)
    grey = ndimage.gaussian_filter(labels, 0.8) * 150 + 50 + rng.normal(0, 6, labels.shape)
    np.save(folder / "grey.npy", np.clip(grey, 0, 255).astype(np.uint8))
    path = folder / "scene.toml"
    path.write_text(scenario_1_text(f'image = "grey.npy"\nvoxel_size = 3e-5\n{segment}', end="20.0", dt="1.0"),
                    encoding="utf-8")
    return path


def test_the_total_interval_covers_the_truth_of_the_other_threshold(tmp_path: Path) -> None:
    path = grey_scene(tmp_path)
    scene = load_scene(path)
    other, (method, threshold) = other_segmentation(path, scene, "scipy")
    assert scene.segmentation is not None and other.segmentation is not None
    assert method == "li" and threshold != scene.segmentation.thresholds[0]
    assert other.segmentation.thresholds == (threshold,)
    data = simulate_measurements(FullModel(assemble(other)), TRUTH, noise=0.01, rng=np.random.default_rng(0))
    plain = identify(FullModel(assemble(scene)), data, UNKNOWNS, particles=8, iterations=4).uncertainty
    checked = identify(FullModel(assemble(scene)), data, UNKNOWNS, particles=8, iterations=4,
                       alternatives={"segmentation": FullModel(assemble(other))}).uncertainty
    assert not plain.lower[0] <= TRUTH["fibre.k"] <= plain.upper[0]  # biased, and the noise alone does not say so
    assert "segmentation" in checked.budget
    assert checked.lower[0] <= TRUTH["fibre.k"] <= checked.upper[0]
    assert checked.lower[1] <= TRUTH["fibre.c"] <= checked.upper[1]


def test_a_given_threshold_is_compared_with_otsus(tmp_path: Path) -> None:
    scene = load_scene(grey_scene(tmp_path, "segment = { thresholds = [110.0] }"))
    assert scene.segmentation is not None and scene.segmentation.other is not None
    assert scene.segmentation.other[0] == "otsu"


def test_identify_command_reports_the_segmentation_row_and_refuses_a_label_image(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = grey_scene(tmp_path)
    csv = tmp_path / "y.csv"
    save_measurements(simulate_measurements(FullModel(assemble(load_scene(path))), TRUTH), csv)
    args = ["identify", str(path), "--measurements", str(csv), "--unknown", "fibre.k=0.05:1", "--unknown",
            "fibre.c=1e5:1e7", "--model", "full", "--particles", "6", "--iterations", "3", "--segmentation-check"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["uncertainty"]["budget"]) >= {"measurement noise", "segmentation"}
    assert out["model"]["segmentation_check"]["method"] == "li"
    assert main(args) == 0
    assert "segmentation" in capsys.readouterr().out
    label = tmp_path / "labels"
    label.mkdir()
    np.save(label / "labels.npy", np.arange(64, dtype=np.int32).reshape(4, 4, 4) % 2)
    (label / "scene.toml").write_text(scenario_1_text('image = "labels.npy"\nvoxel_size = 3e-5', end="20.0",
                                                      dt="1.0"), encoding="utf-8")
    assert main(["identify", str(label / "scene.toml"), "--measurements", str(csv), "--unknown", "fibre.k=0.05:1",
                 "--segmentation-check"]) == 2
    assert "label image" in capsys.readouterr().err
