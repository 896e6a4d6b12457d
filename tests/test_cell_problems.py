"""Homogenisation cell problems (periodic / flux / temperature) against exact values, and multigrid against CHOLMOD."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aromm.cli import main
from aromm.core.errors import InputError, NumericalError
from aromm.core.vocabulary import PhaseSpec
from aromm.homogenization.cell_problems import effective_conductivity, resolve_solver
from aromm.linalg.multigrid import pcg as mg_solver
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

SC_EXACT = 1.39573  # simple-cubic array of spheres, radius L/3, κ = 10 [Rayleigh1892; McPhedranMcKenzie1978]
PHI_SPHERE = 4.0 * np.pi / 81.0
RTOL = 1e-10  # solver tolerance of these tests; tensor tolerances derive from it


def _two_phase(labels: np.ndarray, k0: float | tuple[float, float, float] = 1.0,
               k1: float | tuple[float, float, float] = 10.0, voxel: tuple[float, float, float] = (1e-3,) * 3) -> Scene:
    return Scene(VoxelGeometry(np.asarray(labels), voxel), (PhaseSpec("a", 0, k0), PhaseSpec("b", 1, k1)))


def _means(frac: float, k0: float, k1: float) -> tuple[float, float]:
    return (1 - frac) * k0 + frac * k1, 1.0 / ((1 - frac) / k0 + frac / k1)


@pytest.mark.parametrize("method", ["cholmod", "mg"])
def test_periodic_laminate_is_exact_in_every_direction(method: str) -> None:
    labels = np.zeros((6, 5, 8), dtype=np.int64)
    labels[:, :, [1, 2, 3, 6]] = 1  # layers normal to z, two per period
    scene = _two_phase(labels, 2.0, 30.0, (1e-3, 2e-3, 0.5e-3))
    arithmetic, harmonic = _means(0.5, 2.0, 30.0)
    k = effective_conductivity(scene, "periodic", method, rtol=RTOL).k
    np.testing.assert_allclose(k, np.diag([arithmetic, arithmetic, harmonic]), rtol=1e-8, atol=1e-8 * arithmetic)


@pytest.mark.parametrize("method", ["cholmod", "mg"])
def test_face_conditions_on_a_laminate(method: str) -> None:
    """Fixed temperatures: exact both ways; uniform flux (eq. 13): exact across, strictly below along the layers."""
    labels = np.zeros((4, 4, 8), dtype=np.int64)
    labels[:, :, 2:5] = 1
    scene = _two_phase(labels, 2.0, 30.0)
    arithmetic, harmonic = _means(3 / 8, 2.0, 30.0)
    k_t = effective_conductivity(scene, "temperature", method, rtol=RTOL).k
    np.testing.assert_allclose(np.diag(k_t), [arithmetic, arithmetic, harmonic], rtol=1e-8)
    k_f = effective_conductivity(scene, "flux", method, rtol=RTOL).k
    assert k_f[2, 2] == pytest.approx(harmonic, rel=1e-8)
    assert harmonic < k_f[0, 0] < arithmetic * (1 - 1e-3)


def _diagonal_laminate(width: int, k0: float, k1: float) -> Scene:
    """Layers normal to (1, 1, 0)/√2 as voxel staircases, one period of 2 × width voxels along x and y."""
    i, j = np.meshgrid(np.arange(2 * width), np.arange(2 * width), indexing="ij")
    return _two_phase((((i + j) // width) % 2)[:, :, None], k0, k1)


def test_rotated_laminate_converges_to_the_analytic_off_diagonal_terms() -> None:
    """k = k_a I + (k_h − k_a) n nᵀ with n = (1, 1, 0)/√2: k_xy = (k_h − k_a)/2.

    Along the layers, (1, −1, 0), the staircase medium is invariant, so T = x − y is exact and
    k_xx − k_xy = k_a at every resolution; across them the staircase converges at first order, so the
    Richardson value 2 k(2w) − k(w) is second-order close.
    """
    k0, k1 = 1.0, 10.0
    arithmetic, harmonic = _means(0.5, k0, k1)
    along, across = arithmetic + harmonic, harmonic - arithmetic
    exact = np.array([[along, across], [across, along]]) / 2
    tensors = [effective_conductivity(_diagonal_laminate(w, k0, k1), "periodic", "cholmod", rtol=RTOL).k
               for w in (4, 8, 16)]
    errors = []
    for k in tensors:
        assert k[0, 0] - k[0, 1] == pytest.approx(arithmetic, rel=1e-9)
        np.testing.assert_allclose(k[:2, :2], k[:2, :2].T, rtol=1e-9)
        assert k[2, 2] == pytest.approx(arithmetic, rel=1e-9)  # along z: parallel columns
        errors.append(abs(k[0, 1] - exact[0, 1]))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 1.0, atol=0.1)
    richardson = 2 * tensors[2][:2, :2] - tensors[1][:2, :2]
    np.testing.assert_allclose(richardson, exact, rtol=2e-3)
    mirrored = effective_conductivity(_two_phase(_diagonal_laminate(4, k0, k1).geometry.labels[::-1]), "periodic",
                                      "cholmod", rtol=RTOL).k
    assert mirrored[0, 1] == pytest.approx(-tensors[0][0, 1], rel=1e-9)  # x → −x flips k_xy


def _sphere(n: int) -> Scene:
    c = (np.arange(n) + 0.5) / n - 0.5
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    return _two_phase((x**2 + y**2 + z**2 <= (1 / 3) ** 2).astype(np.int64))


def test_sphere_in_cube_periodic_converges_to_the_simple_cubic_value() -> None:
    """Simple-cubic array, radius L/3, κ = 10 (exact 1.39573).  Voxel fractions scatter around 4π/81; the
    correction dk/dφ (φ − φ_n) with Maxwell's slope removes that, leaving the first-order boundary error."""
    def maxwell(phi: float) -> float:
        return (12 + 18 * phi) / (12 - 9 * phi)

    slope = (maxwell(PHI_SPHERE + 1e-6) - maxwell(PHI_SPHERE - 1e-6)) / 2e-6
    corrected = []
    for n in (12, 24):
        scene = _sphere(n)
        k = effective_conductivity(scene, "periodic", "mg" if n > 12 else "cholmod", rtol=RTOL).k
        np.testing.assert_allclose(np.diag(k), k[0, 0], rtol=1e-7)  # cubic symmetry
        assert np.max(np.abs(k - np.diag(np.diag(k)))) < 1e-7 * k[0, 0]
        corrected.append(k[0, 0] + slope * (PHI_SPHERE - float(scene.geometry.labels.mean())))
    assert corrected[0] > corrected[1] > SC_EXACT  # Q1 on voxels is stiffer: converges from above
    assert 2 * corrected[1] - corrected[0] == pytest.approx(SC_EXACT, rel=3e-3)  # Richardson, first order


def _random(n: int, contrast: float, seed: int = 5) -> Scene:
    labels = (np.random.default_rng(seed).random((n, n + 1, n + 2)) < 0.4).astype(np.int64)
    return _two_phase(labels, 1.0, contrast, (1e-3, 1.2e-3, 0.9e-3))


@pytest.mark.parametrize("contrast", [1e-4, 1e3, 1e4])
@pytest.mark.parametrize("boundary", ["periodic", "flux", "temperature"])
def test_multigrid_gives_the_cholmod_tensor_at_high_contrast(boundary: str, contrast: float) -> None:
    """Same discrete problem, two solvers: agreement to 1e-6 (rtol 1e-10), and a symmetric periodic tensor."""
    scene = _random(14, contrast)
    direct = effective_conductivity(scene, boundary, "cholmod", rtol=RTOL)
    mg = effective_conductivity(scene, boundary, "mg", rtol=RTOL)
    np.testing.assert_allclose(mg.k, direct.k, rtol=1e-6, atol=1e-6 * np.max(np.abs(direct.k)))
    assert 0 < max(mg.iterations) < 60
    if boundary == "periodic":
        np.testing.assert_allclose(mg.k, mg.k.T, rtol=1e-6, atol=1e-6 * np.max(np.abs(mg.k)))
        assert np.all(np.linalg.eigvalsh((mg.k + mg.k.T) / 2) > 0)


@pytest.mark.parametrize("kind", ["conducting", "insulating"])
def test_multigrid_converges_on_thin_walls(kind: str) -> None:
    """One-voxel walls of contrast 1e4 (a closed-cell foam skeleton, or insulating sheets): converged and exact
    along the walls' planes where the walls are full laminae."""
    labels = np.zeros((16, 16, 16), dtype=np.int64)
    labels[::4] = 1
    labels[:, ::4] = 1
    k_wall, k_cell = (1e4, 1.0) if kind == "conducting" else (1e-4, 1.0)
    scene = _two_phase(labels, k_cell, k_wall)
    mg = effective_conductivity(scene, "periodic", "mg", rtol=RTOL)
    direct = effective_conductivity(scene, "periodic", "cholmod", rtol=RTOL)
    np.testing.assert_allclose(mg.k, direct.k, rtol=1e-6, atol=1e-6 * np.max(np.abs(direct.k)))
    frac = float(labels.mean())
    assert mg.k[2, 2] == pytest.approx(_means(frac, k_cell, k_wall)[0], rel=1e-8)  # z along every wall


def test_multigrid_failure_is_a_numerical_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mg_solver, "MAX_ITERATIONS", 2)
    with pytest.raises(NumericalError, match=r"multigrid-preconditioned CG.*2 iterations"):
        effective_conductivity(_random(10, 1e3), "periodic", "mg", rtol=1e-12)


def test_solver_and_boundary_choices_are_checked() -> None:
    assert resolve_solver("auto", 80**3) == "mg"
    assert resolve_solver("auto", 10**3) in ("cholmod", "splu")
    with pytest.raises(InputError, match="allowed"):
        resolve_solver("gmres", 10)
    with pytest.raises(InputError, match="periodic, flux, temperature"):
        effective_conductivity(_random(4, 10.0), "mixed")
    with pytest.raises(InputError, match=r"\(0, 1\)"):
        effective_conductivity(_random(6, 10.0), "periodic", "mg", rtol=2.0)


def test_cli_homogenize_periodic_by_default_with_multigrid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    labels = np.zeros((6, 6, 6), dtype=np.uint8)
    labels[:, :, :3] = 1
    np.save(tmp_path / "img.npy", labels)
    scene = tmp_path / "scene.toml"
    scene.write_text('[geometry]\nimage = "img.npy"\nvoxel_size = 1e-3\n[phases.a]\nlabel = 0\nk = 1.0\n'
                     '[phases.b]\nlabel = 1\nk = 10.0\n', encoding="utf-8")
    assert main(["homogenize", str(scene), "--solver", "mg", "--rtol", "1e-10", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["boundary"], out["solver"]) == ("periodic", "mg")
    np.testing.assert_allclose(out["k"], np.diag([5.5, 5.5, 2 / 1.1]), rtol=1e-8, atol=1e-8)
    assert main(["homogenize", str(scene), "--rtol", "0"]) == 2
    assert main(["homogenize", str(scene), "--solver", "gmres"]) == 2
