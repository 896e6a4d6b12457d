"""The periodic cell in matrix-free finite volumes (aromm.fv.stencil.periodic_stencil, aromm.fv.kernels,
aromm.fv.multigrid, aromm.homogenization.fv_periodic) against independent truths: the periodic 7-point matrix
written cell by cell, the Galerkin product of the aggregation, a laminate's exact tensor (arithmetic mean along the
layers, harmonic across: exact for two-point fluxes with harmonic face conductances), and the assembled incidence
solved directly, within bounds derived from the CG tolerance and the links' float32 rounding."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import scipy.sparse as sp

from aromm.core.anisotropy import PhaseTensor
from aromm.core.vocabulary import PhaseSpec
from aromm.fv.kernels import kernels
from aromm.fv.multigrid import VolumeMultigrid
from aromm.fv.stencil import LINK_ROUNDING, Stencil, assembled, coarsen, periodic_stencil
from aromm.fv.volumes import winding_axes
from aromm.homogenization import fv_periodic
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

EPS = np.finfo(float).eps
VOXEL = (1e-3, 2e-3, 1.5e-3)
BACKENDS = ["numpy", pytest.param("numba", marks=pytest.mark.skipif(kernels().name != "numba",
                                                                       reason="numba not installed"))]


def _k(shape: tuple[int, int, int], contrast: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    k = np.where(rng.random(shape) < 0.5, contrast, 1.0)
    k[rng.random(shape) < 0.15] = 0.0  # insulating cells: some cells lose every link
    return k


def _written(k: np.ndarray) -> sp.csr_array:
    """The periodic operator Σ_links g (x_i − x_j), written link by link (neighbours mod n, harmonic means)."""
    shape = k.shape
    n = k.size
    a = sp.lil_array((n, n))
    for idx in np.ndindex(shape):
        i = np.ravel_multi_index(idx, shape)
        for axis in range(3):
            if shape[axis] == 1:
                continue
            nxt = list(idx)
            nxt[axis] = (nxt[axis] + 1) % shape[axis]
            j = np.ravel_multi_index(tuple(nxt), shape)
            ka, kb = k[idx], k[tuple(nxt)]
            g = 0.0 if ka + kb == 0 else 2 * ka * kb / (ka + kb) * np.prod(VOXEL) / VOXEL[axis] ** 2
            a[i, i] += g
            a[j, j] += g
            a[i, j] -= g
            a[j, i] -= g
    return sp.csr_array(a)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("shape", [(6, 4, 8), (2, 4, 1), (5, 4, 3)])
def test_periodic_kernels_apply_the_matrix_written_link_by_link(backend: str, shape: tuple[int, int, int]) -> None:
    k = _k(shape, 100.0)
    st = periodic_stencil((k, k, k), VOXEL)
    ops, a = kernels(backend), _written(k)
    dead = sp.diags_array((a.diagonal() == 0).astype(float))  # a cell without links: a unit row, kept at zero
    assert abs(assembled(st) - a - dead).max() <= 2 * LINK_ROUNDING * abs(a).max()  # the coarsest level's matrix
    a = sp.csr_array(assembled(st) - dead)  # the float32 links' own matrix: the kernels apply it to rounding
    rng = np.random.default_rng(1)
    x, b = rng.standard_normal(shape), rng.standard_normal(shape)
    scale = float(abs(a).max()) * 8 * EPS  # 7 terms summed per row, each rounded once
    out = np.empty(shape)
    ops.product(st, x, out)
    assert np.abs(out.ravel() - a @ x.ravel()).max() <= scale * np.abs(x).max()
    ops.residual(st, b, x, out)
    assert np.abs(out - (b - (a @ x.ravel()).reshape(shape))).max() <= scale * np.abs(x).max()
    if any(n % 2 for n in shape):
        return  # an odd periodic axis is never swept red–black (aromm.fv.multigrid smooths it by Jacobi)
    # one red sweep is a Gauss–Seidel step on the red unknowns with the black ones fixed (even axes: the wrapped
    # neighbour of a cell has the other colour); a cell without links keeps its value
    y = x.copy()
    ops.sweep(st, b, y, 0)
    red = (np.indices(shape).sum(axis=0) % 2 == 0).ravel()
    dense = a.toarray()
    live = dense.diagonal() > 0
    expect = x.ravel().copy()
    update = red & live
    expect[update] = (b.ravel()[update] - (dense[update] * ~red) @ x.ravel()) / dense.diagonal()[update]
    assert np.abs(y.ravel() - expect).max() <= 1e3 * EPS * np.abs(expect).max()


@pytest.mark.parametrize("shape", [(8, 6, 4), (7, 6, 5)])
def test_the_periodic_coarse_stencil_is_the_galerkin_product(shape: tuple[int, int, int]) -> None:
    """2 × 2 × 2 aggregates (on an odd axis the last cell alone, joined to the first by the wrapped link)."""
    st = periodic_stencil((_k(shape, 1e3),) * 3, VOXEL)
    coarse_shape = tuple((n + 1) // 2 for n in shape)
    rows = [np.ravel_multi_index(idx, shape) for idx in np.ndindex(shape)]
    cols = [np.ravel_multi_index(tuple(i // 2 for i in idx), coarse_shape) for idx in np.ndindex(shape)]
    p = sp.csr_array(sp.coo_array((np.ones(len(rows)), (rows, cols)), shape=(len(rows), int(np.prod(coarse_shape)))))
    galerkin = (p.T @ _links_only(st) @ p).toarray()
    coarse = coarsen(st)
    assert coarse.periodic and coarse.shape == coarse_shape
    assert np.abs(_links_only(coarse).toarray() - galerkin).max() <= 2 * LINK_ROUNDING * np.abs(galerkin).max()


def _links_only(st: Stencil) -> sp.csr_array:
    """The stencil's matrix without the unit rows :func:`assembled` gives the cells that carry no equation."""
    return sp.csr_array(assembled(st) - sp.diags_array(1.0 - st.alive().ravel()))


def _scene(labels: np.ndarray, phases: tuple[PhaseSpec, ...]) -> Scene:
    return Scene(VoxelGeometry(labels, VOXEL), phases, discretisation="fv")  # type: ignore[arg-type]


@pytest.mark.parametrize(("walls", "k_wall", "k_gap"), [(2, 3.0, 0.5), (1, 1.0, 1e-4)])
def test_a_laminate_gives_the_arithmetic_and_harmonic_means(walls: int, k_wall: float, k_gap: float) -> None:
    """Layers across x (``walls`` voxels of k_wall, as many of k_gap, repeated; also one-voxel walls at contrast
    1e4): k_xx = 1 / mean(1/k), k_yy = k_zz = mean(k), no coupling; CG to rtol 1e-10 (its error enters the energy
    form quadratically) and the links' float32."""
    labels = np.zeros((8, 6, 4), dtype=int)
    for start in range(walls, 8, 2 * walls):
        labels[start:start + walls] = 1
    phases = (PhaseSpec("a", 0, k_wall), PhaseSpec("b", 1, k_gap))
    k = fv_periodic._stencil(_scene(labels, phases), 1e-10)
    expect = np.diag([1.0 / np.mean([1 / k_wall, 1 / k_gap]), *[(k_wall + k_gap) / 2] * 2])
    assert np.all(np.abs(k - expect) <= 4 * LINK_ROUNDING * np.abs(expect).max(axis=0))


@pytest.mark.parametrize("contrast", [10.0, 1e3, 1e4])
def test_the_tensor_agrees_with_the_assembled_direct_solve(contrast: float,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Three phases (one insulating), the multigrid forced to three levels.  Bound: the links' float32 rounding
    (LINK_ROUNDING of k, twice: stencil and assembled-incidence solves differ by it at most on each side) and the
    solve's error: with r_j = b_j − A T̃_j, ‖r_j‖ ≤ rtol ‖b_j‖, the energy form moves by r_jᵀ A⁺ r_j ≤ ‖r_j‖² / λ⁺
    and the off-diagonal form by |T̃*_iᵀ r_j| ≤ ‖T̃*_i‖ ‖r_j‖ (λ⁺ the smallest non-zero eigenvalue, T̃* the exact
    correctors, both of the matrix written link by link)."""
    levels = []

    def forced(stencil: Stencil, rtol: float) -> VolumeMultigrid:
        levels.append(VolumeMultigrid(stencil, rtol, coarsest=30))
        return levels[-1]

    monkeypatch.setattr(fv_periodic, "VolumeMultigrid", forced)
    rng = np.random.default_rng(5)
    labels = rng.integers(0, 3, size=(16, 12, 8))
    phases = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, contrast), PhaseSpec("c", 2, 0.0))
    rtol = 1e-7
    k_mg = fv_periodic._stencil(_scene(labels, phases), rtol)
    assert [lv.stencil.shape for lv in levels[0].levels] == [(16, 12, 8), (8, 6, 4), (4, 3, 2)]
    k_direct = fv_periodic._assembled(_scene(labels, phases), "splu", 1e-12)
    k = np.array([1.0, contrast, 0.0])[labels]
    a = _written(k).toarray()
    eig = np.linalg.eigvalsh(a)
    smallest = float(eig[eig > 1e-9 * eig.max()].min())
    volume = float(np.prod(labels.shape) * np.prod(VOXEL))
    st = periodic_stencil((k, k, k), VOXEL)
    rhs = [(VOXEL[j] * (st.links[j].astype(float) - np.roll(st.links[j].astype(float), 1, axis=j))).ravel()
           for j in range(3)]
    exact = [np.linalg.lstsq(a, r, rcond=None)[0] for r in rhs]
    for i in range(3):
        for j in range(3):
            solve = (rtol * np.linalg.norm(rhs[j])) ** 2 / smallest if i == j else \
                np.linalg.norm(exact[i]) * rtol * np.linalg.norm(rhs[j])
            bound = solve / volume + 2 * LINK_ROUNDING * np.abs(k_direct).max() + 1e4 * EPS * contrast
            assert abs(k_mg[i, j] - k_direct[i, j]) <= bound, (i, j, k_mg[i, j], k_direct[i, j], bound)


def test_odd_sizes_run_the_multigrid_and_rotated_tensors_the_assembled_operator(
        caplog: pytest.LogCaptureFixture) -> None:
    """An odd periodic axis is smoothed by Jacobi (red–black colours clash at its wrap): the tensor equals the
    assembled direct solve's within the links' float32 rounding and the CG's tolerance (as in
    test_the_tensor_agrees_with_the_assembled_direct_solve, whose bound is far below 1e-6 here); a rotated tensor
    still takes pyamg, and says so."""
    labels = np.zeros((5, 7, 3), dtype=int)
    labels[::2] = 1
    labels[:, 1::3] = 2
    phases = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 2.0), PhaseSpec("c", 2, 30.0))
    odd = effective_conductivity(_scene(labels, phases), "periodic", "mg", rtol=1e-10)
    direct = fv_periodic._assembled(_scene(labels, phases), "splu", 1e-12)
    assert odd.method == "mg"
    assert np.all(np.abs(odd.k - direct) <= 1e-6 * np.abs(direct).max())
    fibre = PhaseSpec("b", 1, 2.0, tensor=PhaseTensor("fibre", (2.0, 1.0), ((0.6, 0.0, 0.8),)))
    with caplog.at_level(logging.INFO, logger=fv_periodic.__name__):
        result = effective_conductivity(_scene(labels, (phases[0], fibre, phases[2])), "periodic", "mg")
    assert result.method == "amg" and "rotated tensor" in caplog.text


@pytest.mark.parametrize("shape", [(16, 12, 20), (15, 12, 21)])
def test_the_periodic_v_cycle_is_symmetric_and_positive(shape: tuple[int, int, int]) -> None:
    """CG needs a symmetric preconditioner, positive on the range of the singular operator (the coarsest level's
    pinned factorisation is the inverse of a symmetric restriction; odd axes: Jacobi steps, self-adjoint)."""
    st = periodic_stencil((_k(shape, 1e3, seed=3),) * 3, VOXEL)
    mg = VolumeMultigrid(st, coarsest=100)
    assert len(mg.levels) >= 3
    rng = np.random.default_rng(4)
    a = _links_only(st)
    u, v = (a @ rng.standard_normal(st.cells)).reshape(st.shape), (a @ rng.standard_normal(st.cells)).reshape(st.shape)
    bu, bv = mg.precondition(u, np.empty(st.shape)), mg.precondition(v, np.empty(st.shape))
    assert float(np.vdot(v, bu)) == pytest.approx(float(np.vdot(u, bv)), rel=1e-10)
    assert float(np.vdot(u, bu)) > 0 and float(np.vdot(v, bv)) > 0


@pytest.mark.parametrize("solver", ["mg", "splu"])
def test_an_axis_without_a_winding_path_gives_zero_exactly(solver: str, caplog: pytest.LogCaptureFixture) -> None:
    """Conducting slabs cut by insulating planes across x: no path winds around the box along x, so the row and
    column of x are 0 exactly (said in the log); along the slabs each conducts like a laminate's layers (the
    insulating planes are 2 of 8 voxels thick: k_yy = k_zz = 6/8 of the conductor's)."""
    labels = np.ones((8, 4, 6), dtype=int)
    labels[3] = labels[7] = 0
    phases = (PhaseSpec("void", 0, 0.0), PhaseSpec("solid", 1, 2.0))
    with caplog.at_level(logging.INFO, logger=fv_periodic.__name__):
        result = effective_conductivity(_scene(labels, phases), "periodic", solver)
    assert "winds around the periodic cell along x" in caplog.text
    assert np.all(result.k[0] == 0.0) and np.all(result.k[:, 0] == 0.0)
    assert np.abs(np.diag(result.k)[1:] - 1.5).max() <= 4 * LINK_ROUNDING * 2.0


def test_winding_follows_loops_that_cross_the_box_more_than_once() -> None:
    """A staircase that climbs one voxel in y per voxel in x closes on itself only across both faces: it winds
    along x and y together; the same staircase cut in its middle winds along neither."""
    n = 4
    stair = np.zeros((n, n, 1), dtype=bool)
    for i in range(n):
        stair[i, i] = stair[i, (i + 1) % n] = True
    assert winding_axes(stair)[:2] == (True, True)
    cut = stair.copy()
    cut[2] = False
    assert winding_axes(cut)[:2] == (False, False)
