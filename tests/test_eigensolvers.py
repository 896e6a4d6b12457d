"""Chunked LOBPCG (aromm.linalg.eigensolvers) and its block multigrid preconditioner against independent truths:
the separable discrete spectrum of a homogeneous box, ARPACK shift-invert on heterogeneous images, the exact
trilinear Steklov mode of a cube, and the symmetry and mesh-independence of the preconditioner."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scene_text import scenario_1
from test_reduced import exact_outputs

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.linalg import eigensolvers
from aromm.linalg.block_multigrid import BlockMultigrid
from aromm.linalg.eigensolvers import EigenProgress, choose_eigensolver, smallest_eigenpairs
from aromm.reduction.modal_bases import RESIDUAL_TOL, dirichlet_modes, reference_operators, steklov_modes, zero_modes
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble
from aromm.studies.chavez2020 import loading, small_wood

K, C = 2.0, 3.0e6  # W/(m K), J/(m3 K)


def box(shape: tuple[int, int, int], size: float = 1e-4) -> ThermalSystem:
    return assemble_voxels(np.zeros(shape, dtype=int), (size,) * 3, [PhaseSpec("solid", 0, K, C)], (),
                           time=TimeGrid(1.0, 0.1), outputs=["z0"])


def two_phase(n: int, *, k_ratio: float = 12.0, c_ratio: float = 3.3e3, seed: int = 0) -> ThermalSystem:
    labels = (np.random.default_rng(seed).random((n, n, n)) < 0.4).astype(int)
    return assemble_voxels(labels, (5e-6,) * 3,
                           [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.025 * k_ratio, 1.2e3 * c_ratio)],
                           [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)], time=TimeGrid(1.0, 0.1),
                           outputs=["z0", "z1"])


def q1_dirichlet_1d(n: int, h: float) -> np.ndarray:
    """Eigenvalues of the 1-D Q1 pencil (stiffness, consistent mass), both ends fixed: 6(1 − cos θ)/(h²(2 + cos θ))."""
    theta = np.arange(1, n) * np.pi / n
    return 6.0 * (1.0 - np.cos(theta)) / (h**2 * (2.0 + np.cos(theta)))


def test_dirichlet_spectrum_of_a_box_is_the_separable_q1_spectrum() -> None:
    # K = Σ k_x ⊗ M_y ⊗ M_z (Q1 on a tensor grid), so the discrete eigenvalues are (k/c)(θ_i + θ_j + θ_l).
    shape, h = (10, 12, 14), 1e-4
    ops = reference_operators(box(shape, h))
    one_d = [q1_dirichlet_1d(n, h) for n in shape]
    exact = np.sort((one_d[0][:, None, None] + one_d[1][None, :, None] + one_d[2][None, None, :]).ravel())[:45]
    lam, vec = dirichlet_modes(ops, 45, eigensolver="lobpcg")
    np.testing.assert_allclose(lam, K / C * exact, rtol=1e-9)
    gram = vec.T @ (ops.capacity @ vec)
    assert np.abs(gram - np.eye(45)).max() < 1e-8


@pytest.mark.parametrize(("k_ratio", "c_ratio"), [(12.0, 3.3e3), (1e4, 1.0), (1e-3, 1e4)])
def test_lobpcg_matches_arpack_on_heterogeneous_images(k_ratio: float, c_ratio: float) -> None:
    ops = reference_operators(two_phase(12, k_ratio=k_ratio, c_ratio=c_ratio), {})
    for family in (dirichlet_modes, steklov_modes):
        lam_a, vec_a = family(ops, 30, eigensolver="arpack")
        lam_l, vec_l = family(ops, 30, eigensolver="lobpcg")
        np.testing.assert_allclose(lam_l, lam_a, rtol=1e-8)
        # the same invariant subspace: both families are K0-orthogonal, so the K0-projection of the LOBPCG modes
        # onto the ARPACK ones keeps their K0-norm (the last pairs may sit in a cluster cut by the count: first 25)
        va, vl = (v / np.sqrt(np.einsum("ij,ij->j", v, ops.stiffness @ v)) for v in (vec_a, vec_l[:, :25]))
        proj = va.T @ (ops.stiffness @ vl)
        np.testing.assert_allclose(np.linalg.norm(proj, axis=0), 1.0, atol=1e-6)


def test_steklov_cube_exact_trilinear_mode_by_lobpcg() -> None:
    # u = (x − a/2)(y − a/2)(z − a/2) is a discrete Steklov mode with λ = 12 k0/(c a²) (tests/test_modes.py).
    a = 1.2e-3
    ops = reference_operators(box((12, 12, 12), a / 12))
    lam, _ = steklov_modes(ops, 40, eigensolver="lobpcg")
    exact = 12.0 * K / (C * a**2)
    assert np.min(np.abs(lam - exact)) / exact < 1e-9


def test_residuals_and_constraints_of_the_raw_solver() -> None:
    ops = reference_operators(two_phase(11), {})
    b = ops.zeta * ops.boundary
    z = zero_modes(ops)
    got = smallest_eigenpairs(ops.stiffness, b, 25, shift=-1e-3, constraints=z, rng=np.random.default_rng(1),
                              block=8, guard=3)
    m = ops.stiffness + 1e-3 * b
    v, lam = got.vectors, got.eigenvalues
    r = ops.stiffness @ v - (b @ v) * lam
    rel = np.linalg.norm(r, axis=0) / (np.linalg.norm(ops.stiffness @ v, axis=0) + lam * np.linalg.norm(b @ v, axis=0))
    assert rel.max() < 2 * eigensolvers.TOL < RESIDUAL_TOL  # the solver's own tolerance (pencil residual ≈ this one)
    np.testing.assert_allclose(v.T @ (m @ v), np.eye(25), atol=1e-10)
    # no constant component: 1ᵀBv = −1ᵀr/λ for K1 = 0, so the B-cosine of each trace with the constant is
    # bounded by the residual tolerance
    ones = np.ones(ops.n)
    cosine = (ones @ (b @ v)) / np.sqrt((ones @ (b @ ones)) * np.einsum("ij,ij->j", v, b @ v))
    assert np.abs(cosine).max() < eigensolvers.TOL
    assert np.all(np.diff(lam) >= 0)


def test_progress_reports_converged_pairs_and_iterations() -> None:
    ops = reference_operators(two_phase(10), {})
    reports: list[EigenProgress] = []
    dirichlet_modes(ops, 20, eigensolver="lobpcg", progress=reports.append)
    converged = [r.converged for r in reports]
    assert converged[-1] == 20 and all(r.wanted == 20 for r in reports)
    assert reports[-1].iterations > 0
    assert np.all(np.diff([r.iterations for r in reports]) >= 0)


def test_unconverged_lobpcg_raises_numerical_error() -> None:
    ops = reference_operators(two_phase(10), {})
    with pytest.raises(NumericalError, match="LOBPCG"):
        smallest_eigenpairs(ops.stiffness[ops.interior][:, ops.interior], ops.capacity[ops.interior][:, ops.interior],
                            10, rng=np.random.default_rng(0), max_iterations=2)


def test_unknown_eigensolver_is_an_input_error() -> None:
    with pytest.raises(InputError, match="lobpcg"):
        choose_eigensolver("lanczos", 10)
    assert choose_eigensolver("auto", eigensolvers.LOBPCG_ABOVE + 1) == "lobpcg"
    assert choose_eigensolver("auto", eigensolvers.LOBPCG_ABOVE) == "arpack"


def test_block_multigrid_is_symmetric_and_mesh_independent() -> None:
    rng = np.random.default_rng(0)
    iterations = []
    for n in (12, 24):
        ops = reference_operators(two_phase(n), {})
        k = sp.csr_array(ops.stiffness[ops.interior][:, ops.interior])
        t = BlockMultigrid(k, rng=rng)
        x, y = rng.standard_normal((2, k.shape[0]))
        assert x @ t(y) == pytest.approx(y @ t(x), rel=1e-10)  # symmetric: usable inside CG and LOBPCG
        assert x @ t(x) > 0
        both = t(np.column_stack([x, y]))  # a block is the same as its columns
        np.testing.assert_allclose(both[:, 1], t(y), rtol=1e-12, atol=1e-14 * np.abs(both).max())
        steps: list[np.ndarray] = []
        _, info = spla.cg(k, x, rtol=1e-8, M=spla.LinearOperator(k.shape, matvec=t), callback=steps.append)
        assert info == 0
        iterations.append(len(steps))
    assert iterations[1] <= iterations[0] + 4, iterations


def test_reduced_model_from_lobpcg_bases_agrees_with_direct_bases_within_its_own_error(tmp_path) -> None:
    # A wood-like VER (aromm.studies.chavez2020.small_wood), scenario 1 of [Chavez2020] over 6 s, bases and reference
    # case at the paper's properties: the reduced model built from LOBPCG bases must agree with the one from
    # ARPACK bases closer than either is to the exact full model.
    scene = loading(small_wood(9), "z", end=6.0, dt=0.3)
    system = assemble(scene)
    point = {"fibre.k": 0.3, "fibre.c": 4e6}
    roms = {name: reduce(system, order=24, modes=40, eigensolver=name, cache=tmp_path / name,
                         basis_values=scene.reduction.basis, reference_values=scene.reduction.reference)
            for name in ("arpack", "lobpcg")}
    assert roms["lobpcg"].info["eigensolver"] == "lobpcg" and roms["lobpcg"].info["eigen_iterations"] > 0
    times = system.time.times if system.time is not None else np.zeros(1)
    exact = exact_outputs(system, point, times)
    y = {name: rom.simulate(point, times).as_array() for name, rom in roms.items()}
    own_error = np.abs(y["arpack"] - exact).max()
    assert own_error > 0
    agreement = np.abs(y["lobpcg"] - y["arpack"]).max()
    print(f"ROM (ARPACK bases) error {own_error:.2e} °C; LOBPCG vs ARPACK bases {agreement:.2e} °C")
    assert agreement < 0.1 * own_error


def test_cli_reduce_with_lobpcg_bases(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from aromm.cli import main

    np.savez(tmp_path / "img.npz", labels=(np.random.default_rng(3).random((6, 6, 6)) < 0.4).astype(int))
    scene = tmp_path / "s1.toml"
    scene.write_text(scenario_1("img.npz", "5.0e-6", "2.0", "0.1"))
    args = ["reduce", str(scene), "--order", "12", "--modes", "30", "--eigensolver", "lobpcg", "--no-cache", "--json"]
    assert main(args) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["eigensolver"] == "lobpcg" and info["eigen_iterations"] > 0
    assert main([*args[:6], "--eigensolver", "lanczos"]) == 2


def test_long_warm_start_does_not_collapse_and_runs_are_reproducible(monkeypatch: pytest.MonkeyPatch) -> None:
    # Many subspace-iteration steps make a block collapse onto the dominant eigenvectors unless it is
    # re-orthonormalised; implicit updates of M X then lose M-orthonormality and LOBPCG stalls near 1e-5.
    ops = reference_operators(two_phase(12), {})
    k = sp.csr_array(ops.stiffness[ops.interior][:, ops.interior])
    c = sp.csr_array(ops.capacity[ops.interior][:, ops.interior])
    monkeypatch.setattr(eigensolvers, "WARMUP", 8)
    first = smallest_eigenpairs(k, c, 20, rng=np.random.default_rng(5))
    again = smallest_eigenpairs(k, c, 20, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(first.eigenvalues, again.eigenvalues)  # no hidden global random state
    reference, _ = dirichlet_modes(ops, 20, eigensolver="arpack")
    np.testing.assert_allclose(first.eigenvalues, reference, rtol=1e-8)


def test_float32_basis_storage_changes_face_means_below_the_rounding_of_the_modes(tmp_path) -> None:
    # Rounding the modes to single precision (relative 6e-8) perturbs the Galerkin subspace by as much; the
    # face means of the reduced model move by far less than that relative to their size.
    scene = loading(small_wood(8), "z", end=6.0, dt=0.3)
    system = assemble(scene)
    point = {"fibre.k": 0.3, "fibre.c": 4e6}
    y = {}
    for storage in ("float64", "float32"):
        rom = reduce(system, order=20, modes=30, basis_storage=storage, cache=tmp_path,
                     basis_values=scene.reduction.basis, reference_values=scene.reduction.reference)
        y[storage] = rom.simulate(point).as_array()
    scale = np.abs(y["float64"]).max()
    assert np.abs(y["float32"] - y["float64"]).max() < np.finfo(np.float32).eps * scale
    with pytest.raises(InputError, match="float32"):
        reduce(system, order=20, modes=30, basis_storage="float16", cache=False)
