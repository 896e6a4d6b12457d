"""``Scene.refined`` and ``--refine R``: sub-voxel elements keep the geometry, the fractions and exact answers."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scene_text import scenario_1

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.full.solve import steady_field
from aromm.homogenization.properties import homogenize
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble

PHASES = (PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6))


def _random_scene(shape: tuple[int, int, int] = (3, 4, 2)) -> Scene:
    labels = np.random.default_rng(3).integers(0, 2, size=shape).astype(np.uint8)
    return Scene(VoxelGeometry(labels, (1e-3, 2e-3, 0.5e-3)), PHASES)


@pytest.mark.parametrize("factor", [1, 2, 3])
def test_refined_scene_keeps_box_fractions_and_labels(factor: int) -> None:
    scene = _random_scene()
    fine = scene.refined(factor)
    coarse_labels, fine_labels = scene.geometry.labels, fine.geometry.labels
    assert fine_labels.shape == tuple(factor * n for n in coarse_labels.shape)
    assert fine_labels.dtype == coarse_labels.dtype
    np.testing.assert_allclose(fine.size, scene.size, rtol=1e-15)
    fractions, fine_fractions = scene.volume_fractions(), fine.volume_fractions()
    for name in fractions:
        assert fine_fractions[name] == pytest.approx(fractions[name], rel=1e-12)
    # every sub-voxel carries the label of the voxel it lies in
    i, j, k = (np.arange(n) // factor for n in fine_labels.shape)
    np.testing.assert_array_equal(fine_labels, coarse_labels[np.ix_(i, j, k)])


def test_refined_laminate_keeps_the_exact_means() -> None:
    """Q1 is exact on a laminate at any resolution: refining changes nothing but the cost."""
    labels = np.zeros((3, 2, 4), dtype=np.int64)
    labels[:, :, 1:3] = 1
    scene = Scene(VoxelGeometry(labels, (1e-3, 1e-3, 1e-3)), PHASES)
    harmonic = 1.0 / (0.5 / 0.025 + 0.5 / 0.3)
    arithmetic = 0.5 * (0.025 + 0.3)
    k = homogenize(scene.refined(2), boundary="temperature")
    np.testing.assert_allclose(np.diag(k), [arithmetic, arithmetic, harmonic], rtol=1e-9)


def test_refined_slab_has_the_same_face_means() -> None:
    """Homogeneous slab under flux/convection: the linear steady profile is exact on any Q1 mesh."""
    scene = Scene(VoxelGeometry(np.zeros((2, 2, 3), dtype=np.int64), (1e-3,) * 3), (PhaseSpec("m", 0, 2.0),),
                  (FaceSpec("z0", flux=100.0), FaceSpec("z1", h=10.0)), outputs=("z0", "z1"))
    means = []
    for factor in (1, 3):
        system = assemble(scene.refined(factor))
        field = steady_field(system)
        means.append([float(system.observation[f] @ field) for f in ("z0", "z1")])
    # T(z1) = q/h = 10 K, T(z0) = 10 + q L / k = 10.15 K
    np.testing.assert_allclose(means, [[10.15, 10.0]] * 2, rtol=1e-10)


@pytest.mark.parametrize("factor", [0, -2, 1.5, True, "2"])
def test_refine_refuses_a_factor_that_is_not_a_positive_integer(factor: object) -> None:
    with pytest.raises(InputError, match="positive integer"):
        _random_scene().refined(factor)  # type: ignore[arg-type]


def test_refine_refuses_a_problem_larger_than_the_budget() -> None:
    scene = _random_scene((10, 10, 10))
    assert scene.refined(2, bytes_per_voxel=100.0, budget=8e5).geometry.labels.shape == (20, 20, 20)
    with pytest.raises(InputError, match="30×30×30"):
        scene.refined(3, bytes_per_voxel=100.0, budget=8e5)


def test_refine_refuses_a_mesh_scene() -> None:
    scene = replace(_random_scene(), geometry=object())  # type: ignore[arg-type]
    with pytest.raises(InputError, match="mesh"):
        scene.refined(2)


def _scene_file(tmp_path: Path) -> Path:
    labels = np.zeros((2, 2, 4), dtype=np.uint8)
    labels[:, :, 2:] = 1
    np.save(tmp_path / "img.npy", labels)
    path = tmp_path / "scene.toml"
    path.write_text(scenario_1("img.npy", "1.0e-3", "8000.0", "2000.0"), encoding="utf-8")
    return path


def test_cli_refine_on_homogenize_simulate_and_reduce(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _scene_file(tmp_path)
    assert main(["homogenize", str(path), "--boundary", "temperature", "--refine", "2", "--json"]) == 0
    k = np.array(json.loads(capsys.readouterr().out)["k"])
    assert k[2, 2] == pytest.approx(1.0 / (0.5 / 0.025 + 0.5 / 0.3), rel=1e-9)  # layers normal to z: harmonic
    outs = []
    for refine in ("1", "2"):
        assert main(["simulate", str(path), "--refine", refine, "--json"]) == 0
        outs.append(json.loads(capsys.readouterr().out)["mean_T"]["z1"])
    # a finer discretisation of the same transient (layers normal to z: at steady state Q1 is exact at any
    # resolution, so the two approach each other as t grows; 8000 s ≈ 38 fibre time constants L²c/k)
    assert outs[0] != outs[1]
    assert outs[1][-1] == pytest.approx(outs[0][-1], rel=1e-3)
    assert main(["reduce", str(path), "--order", "4", "--refine", "2", "--no-cache", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["order"] == 4
    assert main(["homogenize", str(path), "--refine", "0"]) == 2
