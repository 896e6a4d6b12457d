"""``factorize(method="mg")``: geometric multigrid on assembled voxel systems, against CHOLMOD."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import _partition, _points, _split, steady_field
from aromm.linalg.direct import factorize
from aromm.linalg.multigrid.hierarchy import assembled_matrix
from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.pcg import FLOOR_FACTOR, MultigridSolver

RTOL = 1e-10


def _system(shape: tuple[int, int, int], contrast: float = 12.0):  # type: ignore[no-untyped-def]
    labels = (np.random.default_rng(2).random(shape) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, (0.3, 0.025 * contrast, 0.2), 4e6)]
    faces = [FaceSpec("z0", flux=100.0), FaceSpec("z1", h=20.0), FaceSpec("x0", T=1.0)]
    return assemble_voxels(labels, (1e-3, 1e-3, 2e-3), phases, faces, time=TimeGrid(10.0, 1.0))


@pytest.mark.parametrize("contrast", [12.0, 1e4])
def test_mg_steady_field_equals_cholmod(contrast: float) -> None:
    """Fixed temperatures eliminated, convection and orthotropic phases: the same field to the tolerance."""
    system = _system((18, 13, 21), contrast)
    direct = steady_field(system, method="cholmod")
    mg = steady_field(system, method="mg")
    np.testing.assert_allclose(mg, direct, rtol=1e-6, atol=1e-6 * np.abs(direct).max())


def test_mg_time_step_matrix_and_several_right_hand_sides() -> None:
    system = _system((9, 10, 11))
    v = system.values()
    part = _partition(system, v)
    c_ff, _ = _split(sp.csr_array(system.capacity.evaluate(v)), part)
    k_ff, _ = _split(sp.csr_array(system.conductance.evaluate(v)), part)
    a = c_ff / 0.5 + k_ff
    b = np.random.default_rng(0).standard_normal((a.shape[0], 2))
    x = factorize(a, "mg", rtol=RTOL, points=_points(system, part)).solve(b)
    np.testing.assert_allclose(a @ x, b, atol=RTOL * np.linalg.norm(b, axis=0).max() * 10)


def test_mg_needs_a_voxel_grid() -> None:
    a = sp.csr_array(sp.eye(8) * 2.0)
    with pytest.raises(InputError, match="coordinates"):
        factorize(a, "mg")
    with pytest.raises(InputError, match="grid"):
        factorize(a, "mg", points=np.zeros((8, 3)))


def test_fixed_faces_commute_with_galerkin_coarsening() -> None:
    """The first coarse level of a free box operator, constrained afterwards (CoarseLevel.with_fixed), is the
    Galerkin product P₀ᵀ A₀ P₀ of the assembled constrained fine operator (scipy), free rows and columns alike."""
    from aromm.linalg.multigrid.hierarchy import assembled_matrix, fixed_mask, galerkin_levels, prolongation_1d
    from aromm.linalg.multigrid.operator import VoxelOperator

    phase = np.random.default_rng(3).integers(0, 3, size=(9, 10, 11))
    conductivity = np.array([[1.0, 1.0, 1.0], [30.0, 30.0, 30.0], [0.5, 2.0, 4.0]])
    free = VoxelOperator(phase, conductivity, (1e-3, 2e-3, 1.5e-3))
    fixed = ("y0", "y1")
    constrained = VoxelOperator(phase, conductivity, (1e-3, 2e-3, 1.5e-3), fixed=fixed)
    level = galerkin_levels(free, coarsest=10)[0].with_fixed(fixed)
    p = sp.kron(sp.kron(prolongation_1d(9, False), prolongation_1d(10, False)), prolongation_1d(11, False))
    galerkin = (p.T @ assembled_matrix(constrained) @ p).toarray()
    mask = fixed_mask(level.node_shape, fixed)
    galerkin[mask] = 0.0
    galerkin[:, mask] = 0.0
    galerkin[mask, mask] = 1.0
    scale = np.abs(galerkin).max()
    assert np.abs(level.matrix.toarray() - galerkin).max() <= 1e-13 * scale


def test_the_matrix_free_rounding_floor_estimates_the_true_one() -> None:
    """rtol = 1e-17 on the matrix-free operator: the solve stops at the floor, whose estimate λ D |x| (no abs(A)
    at hand) is within a factor 1.5 of the true FLOOR_FACTOR ε ‖|A||x|‖ / ‖b‖ of the assembled matrix; a second solve
    (kept vectors reused) gives the same x."""
    phase = (np.random.default_rng(11).random((7, 6, 8)) < 0.4).astype(np.int8)
    op = VoxelOperator(phase, np.array([[0.02] * 3, [20.0] * 3]), (1e-4, 1e-4, 1e-4), fixed=("z0",),
                       capacity=np.array([1e3, 2e6]))
    mg = MultigridSolver(op, rtol=1e-17)
    b = np.random.default_rng(12).standard_normal(op.n)
    b[op.n - op.node_shape[1] * op.node_shape[2]:] += 1.0
    b[: op.node_shape[1] * op.node_shape[2]] = 0.0  # the fixed face z0
    x = mg.solve(b)
    a = sp.csr_array(assembled_matrix(op))
    nb = float(np.linalg.norm(b))
    truth = FLOOR_FACTOR * np.finfo(float).eps * float(np.linalg.norm(abs(a) @ np.abs(x))) / nb
    estimate = mg.floor(x, nb)
    assert truth / 1.5 <= estimate <= 1.5 * truth  # 1.05 here; without its Gershgorin factor λ ≈ 2: 0.52
    assert np.linalg.norm(b - a @ x) / nb <= 1e-17 + estimate
    assert mg.at_floor == 1
    np.testing.assert_array_equal(mg.solve(b), x)
