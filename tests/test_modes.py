"""Dirichlet and Steklov eigenbases (aromm.reduction.modal_bases) against analytic eigenvalues and exact identities."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from aromm.core.cache import NpzCache, default_cache_dir
from aromm.core.errors import InputError, NumericalError
from aromm.core.system import Affine, Coefficient, Term, ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.reduction import modal_bases as modes
from aromm.reduction.modal_bases import compute_basis, dirichlet_modes, reference_operators, steklov_modes, zero_modes

K, C = 2.0, 3.0e6  # W/(m K), J/(m3 K): a "solid" phase (not named fibre/gas: no seed override)


def box(shape: tuple[int, int, int], lengths: tuple[float, float, float], boundary=()) -> ThermalSystem:
    size = tuple(length / n for length, n in zip(lengths, shape, strict=True))
    return assemble_voxels(np.zeros(shape, dtype=int), size, [PhaseSpec("solid", 0, K, C)], boundary,
                           time=TimeGrid(1.0, 0.1), outputs=["z0"])


def two_phase(n: int, seed: int = 0, fraction: float = 0.5) -> ThermalSystem:
    labels = (np.random.default_rng(seed).random((n, n, n)) < fraction).astype(int)
    return assemble_voxels(labels, (5e-6,) * 3, [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)],
                           [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)], time=TimeGrid(1.0, 0.1),
                           outputs=["z0", "z1"])


LENGTHS = (1.0e-3, 1.5e-3, 2.0e-3)


def exact_dirichlet(i: int, j: int, k: int) -> float:
    lx, ly, lz = LENGTHS
    return float(np.pi**2 * K * ((i / lx) ** 2 + (j / ly) ** 2 + (k / lz) ** 2) / C)


def test_dirichlet_box_matches_analytic_with_second_order_convergence() -> None:
    # [Chavez2020, eq. 6] on a homogeneous box: λ = π² k (i²/Lx² + j²/Ly² + k²/Lz²) / c.
    wanted = sorted([exact_dirichlet(1, 1, 1), exact_dirichlet(1, 1, 2), exact_dirichlet(1, 2, 1)])
    errors = []
    for scale in (1, 2):
        ops = reference_operators(box((4 * scale, 6 * scale, 8 * scale), LENGTHS))
        lam, _ = dirichlet_modes(ops, 3)
        assert np.all(lam >= np.array(wanted))  # consistent-mass Q1: upper bounds
        errors.append(np.abs(lam - wanted) / wanted)
    coarse, fine = errors
    assert np.all(fine < 0.02)
    rate = np.log2(coarse / fine)
    assert np.all((rate > 1.8) & (rate < 2.2))


def test_arpack_path_matches_dense(monkeypatch: pytest.MonkeyPatch) -> None:
    ops = reference_operators(two_phase(7))
    lam_dense, vec_dense = dirichlet_modes(ops, 6)
    s_dense, _ = steklov_modes(ops, 6)
    monkeypatch.setattr(modes, "DENSE_LIMIT", 10)
    lam, vec = dirichlet_modes(ops, 6)
    s_lam, _ = steklov_modes(ops, 6)
    np.testing.assert_allclose(lam, lam_dense, rtol=1e-8)
    np.testing.assert_allclose(s_lam, s_dense, rtol=1e-8)
    # same eigenvectors up to sign (distinct eigenvalues of a random two-phase image)
    overlap = np.abs(np.einsum("ij,ij->j", vec, ops.capacity @ vec_dense))
    np.testing.assert_allclose(overlap, 1.0, atol=1e-6)


def test_steklov_cube_contains_exact_trilinear_mode() -> None:
    # On a cube of side a, u = (x−a/2)(y−b/2)(z−c/2) is harmonic with ∂u/∂n = (2/a) u on every face and lies in
    # the Q1 space, so k0 ∂u/∂n = λ ζ u holds exactly for λ = 2 k0/(a ζ), ζ = c a/6 (eq. 8): λ = 12 k0/(c a²).
    a = 1.0e-3
    system = box((6, 6, 6), (a, a, a))
    ops = reference_operators(system)
    assert ops.zeta == pytest.approx(C * a / 6.0, rel=1e-12)
    lam, vec = steklov_modes(ops, 60)
    exact = 12.0 * K / (C * a**2)
    assert np.min(np.abs(lam - exact)) / exact < 1e-9
    # cube symmetry: the lowest non-zero eigenvalue is triple
    np.testing.assert_allclose(lam[:3], lam[0], rtol=1e-9)
    assert lam[3] > lam[0] * (1 + 1e-6)
    # discretely harmonic: (K0 v) vanishes on interior nodes
    interior = ops.interior
    kv = ops.stiffness @ vec
    assert np.abs(kv[interior]).max() < 1e-9 * np.abs(kv).max()


def test_basis_orthogonality_and_zero_mode() -> None:
    system = two_phase(6, seed=3)
    basis = compute_basis(system, 20, 20)
    ops = reference_operators(system)
    v = basis.vectors
    kinds = basis.kinds
    assert list(kinds[:1]) == ["zero"] and basis.count("zero") == 1
    # constant mode: uniform, capacity-normalised (∫ c0 V0² = 1)
    z = v[:, 0]
    np.testing.assert_allclose(z, z[0], rtol=1e-12)
    assert z @ (ops.capacity @ z) == pytest.approx(1.0, rel=1e-12)
    d = v[:, kinds == "dirichlet"]
    s = v[:, kinds == "steklov"]
    # every mode has unit capacity norm
    np.testing.assert_allclose(np.einsum("ij,ij->j", v, ops.capacity @ v), 1.0, rtol=1e-10)
    # Dirichlet: C0-orthogonal, zero on Γ; Steklov: ζB-orthogonal
    gd = d.T @ (ops.capacity @ d)
    assert np.abs(gd - np.eye(gd.shape[0])).max() < 1e-8
    assert np.abs(d[ops.boundary.diagonal() > 0]).max() == 0.0
    gs = s.T @ (ops.boundary @ s)
    assert np.abs(gs - np.diag(np.diag(gs))).max() < 1e-8 * np.abs(np.diag(gs)).max()
    # Dirichlet and Steklov modes are K0-orthogonal exactly (docs/notes/aromm_method.md §3)
    cross = d.T @ (ops.stiffness @ s)
    scale = np.sqrt(np.outer(np.diag(d.T @ ops.stiffness @ d), np.diag(s.T @ ops.stiffness @ s)))
    assert np.abs(cross / scale).max() < 1e-8
    # eigen-residuals
    lam_d = basis.eigenvalues[kinds == "dirichlet"]
    r = ops.stiffness @ d - (ops.capacity @ d) * lam_d
    assert np.linalg.norm(r[ops.interior], axis=0).max() < 1e-7 * np.linalg.norm(ops.stiffness @ d, axis=0).min()


def test_zero_modes_one_per_component_on_a_bond_network() -> None:
    # Two disconnected 1-D chains (a DEM-like system without geometry): two constant modes.
    n = 8
    lap = sp.diags_array([-np.ones(3), 2 * np.ones(4), -np.ones(3)], offsets=[-1, 0, 1]).tolil()
    lap[0, 0] = lap[3, 3] = 1.0
    block = sp.csr_array(sp.block_diag([lap, lap]))
    load = np.zeros(n)
    load[[0, 4]] = 1.0
    system = ThermalSystem(n, conductance=Affine((Term("K", Coefficient(("p.k",)), block, "conduction"),)),
                           capacity=Affine((Term("C", Coefficient(("p.c",)), sp.csr_array(sp.eye(n)), "capacity"),)),
                           load=Affine((Term("U", Coefficient(("q",)), load, "load"),)),
                           parameters={"p.k": 1.0, "p.c": 2.0, "q": 1.0}, time=TimeGrid(1.0, 0.1),
                           boundary=sp.csr_array(sp.diags_array(load)))  # the loaded ends are the boundary
    ops = reference_operators(system)
    z = zero_modes(ops)
    assert z.shape == (n, 2)
    np.testing.assert_allclose(ops.stiffness @ z, 0.0, atol=1e-14)


def test_fixed_temperature_is_refused_with_reason() -> None:
    system = box((3, 3, 3), LENGTHS, [FaceSpec("x0", T=25.0)])
    with pytest.raises(InputError, match="fixed temperatures"):
        reference_operators(system)


def test_unconverged_solver_raises_numerical_error(monkeypatch: pytest.MonkeyPatch) -> None:
    ops = reference_operators(two_phase(5))
    monkeypatch.setattr(modes, "RESIDUAL_TOL", 1e-30)
    with pytest.raises(NumericalError, match="Dirichlet eigensolver: relative residual"):
        dirichlet_modes(ops, 4)


def test_basis_cache_round_trip(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    cache = NpzCache()
    system = two_phase(5, seed=1)
    first = compute_basis(system, 8, 8, cache=cache)
    files = list((tmp_path / "c").glob("basis-*.npz"))
    assert len(files) == 1 and not list((tmp_path / "c").glob("*.tmp"))
    with np.load(files[0], allow_pickle=False) as data:
        assert set(data.files) >= {"vectors", "eigenvalues", "kinds"}
    second = compute_basis(system, 8, 8, cache=cache)
    assert second.info["cached"] == 1.0
    np.testing.assert_array_equal(first.vectors, second.vectors)
    # a scenario with other loads on the same body shares the basis (K0, C0, B unchanged)
    other = assemble_voxels((np.random.default_rng(1).random((5, 5, 5)) < 0.5).astype(int), (5e-6,) * 3,
                            [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)],
                            [FaceSpec("x0", flux=500.0), FaceSpec("x1", h=20.0)], time=TimeGrid(1.0, 0.1))
    assert compute_basis(other, 8, 8, cache=cache).info["cached"] == 1.0
