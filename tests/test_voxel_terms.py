"""Matrix-free voxel terms (aromm.fem.voxel_terms) against the assembled ones of aromm.fem.voxel: every product
the reduction and the full model take (terms, restrictions to the free unknowns, row blocks, weighted sums, the
shifted operator and its Galerkin coarse level, the lifting, the projection, the residual Gram matrix, the
transient) equals the assembled path's to round-off; the Krylov reduced model built on either is the same model
(exact Krylov span at the same points) and converges to the same full model."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
from test_reduced import exact_outputs, random_labels

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid, is_matrix_free, sparse
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.fem.voxel_terms import VoxelTerm, as_voxel_terms, harmonic_extension, shifted_operator, weighted_product
from aromm.full.solve import simulate, transient
from aromm.linalg.multigrid.affine_voxel import AffineLevels
from aromm.linalg.multigrid.assembled import galerkin
from aromm.linalg.multigrid.coarse_stencil import StencilMatrix
from aromm.linalg.multigrid.hierarchy import ElementLevel, assembled_matrix, galerkin_levels
from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.pcg import MultigridSolver
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.lifting import lift, liftings
from aromm.reduction.offline import reduce
from aromm.reduction.residual_gram import ResidualGram
from aromm.reduction.rom import ReducedModel, one_blas_thread
from aromm.reduction.scipy_engine import ScipyEngine

ROUND = 1e-13  # relative: products of a few hundred terms of the same magnitude in another order
BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
SCENARIO = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=2.0)]
FIXED = [FaceSpec("z0", flux=500.0), FaceSpec("x1", T=1.0), FaceSpec("y0", T=-2.0), FaceSpec("z1", h=20.0)]
HELD = [FaceSpec("z0", flux=500.0), FaceSpec("x1", T=1.0), FaceSpec("z1", h=20.0)]


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    with one_blas_thread():
        yield


def body(n: int, faces: list[FaceSpec], matrix_free: bool, shape: tuple[int, int, int] | None = None
         ) -> ThermalSystem:
    """Random two-phase body (contrast 10 in k and c), the wood VER's box size, 20 s at dt 0.1 s."""
    labels = random_labels(n, seed=3) if shape is None else (np.random.default_rng(3).random(shape) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.03, 4e5), PhaseSpec("fibre", 1, 0.3, 4e6)]
    return assemble_voxels(labels, (1e-4, 1.2e-4, 0.9e-4), phases, faces, time=TimeGrid(20.0, 0.1),
                           outputs=["z0", "z1"], initial_T=1.0, matrix_free=matrix_free)


def close(a: np.ndarray, b: np.ndarray, tol: float = ROUND) -> None:
    scale = max(float(np.abs(a).max()), 1e-300)
    assert float(np.abs(np.asarray(a) - np.asarray(b)).max()) <= tol * scale


def test_terms_equal_the_assembled_matrices_on_the_whole_grid_and_on_the_free_unknowns() -> None:
    shape = (5, 4, 6)
    for faces in (SCENARIO, FIXED):
        assembled, free = body(0, faces, False, shape), body(0, faces, True, shape)
        if faces is FIXED:
            assembled, free = lift(assembled), lift(free)
        rng = np.random.default_rng(0)
        x = rng.standard_normal((assembled.n, 3))
        for group in ("conductance", "capacity"):
            for ta, tb in zip(getattr(assembled, group).terms, getattr(free, group).terms, strict=True):
                assert is_matrix_free(tb.operator) and not is_matrix_free(ta.operator)
                a = sp.csr_array(ta.operator)
                assert abs(a - sparse(tb.operator)).max() <= ROUND * abs(a).max()
                close(a @ x, tb.operator @ x)
                close(a.diagonal(), tb.operator.diagonal())
                for start, stop in ((0, 7), (11, 40), (assembled.n - 9, assembled.n), (3, 3 + 2 * 7 * 6)):
                    close((a @ x)[start:stop], tb.operator.row_block(start, stop, x), ROUND * 10)
                    work = np.full(tb.operator.slab_size(stop - start) * 3, np.nan)  # large enough: used
                    rows = tb.operator.row_block(start, stop, np.asfortranarray(x), work)
                    close((a @ x)[start:stop], rows, ROUND * 10)
                    assert np.isfinite(work).any() or tb.operator.kind == "exchange"  # the slab went there
        for ta, tb in zip(assembled.load.terms, free.load.terms, strict=True):  # lifting loads, face loads
            close(np.asarray(ta.operator), np.asarray(tb.operator))
        for ta, tb in zip(assembled.initial.terms, free.initial.terms, strict=True):
            close(np.asarray(ta.operator), np.asarray(tb.operator))


def test_shifted_operator_and_its_coarse_level_are_the_weighted_sum_and_its_galerkin_product() -> None:
    """K(μ) + s C(μ) + h H with fixed faces: the matrix-free operator is the assembled sum with identity rows on
    the fixed nodes; its first coarse level (look-up by phase codes, convection faces coarsened) is Pᵀ A P with
    the trilinear P masked on fixed nodes, formed by scipy from the assembled sum (the independent truth)."""
    system = lift(body(0, FIXED, True, (9, 8, 11)))
    terms = as_voxel_terms([t.operator for t in (*system.conductance.terms, *system.capacity.terms)])
    weights = [0.7, 0.03, 25.0, 3e4, 2e5]
    op = shifted_operator(terms, weights)
    total = sum(w * t.tocsr() for w, t in zip(weights, terms, strict=True))
    grid = assembled_matrix(op)
    free = terms[0].free
    close(grid[free][:, free].toarray(), total.toarray())
    x = np.random.default_rng(1).standard_normal(op.n)
    close(op @ x, grid @ x)
    close(op.diagonal(), grid.diagonal())
    block = np.random.default_rng(5).standard_normal((op.n, 3))  # columns sharing each slab's gathered weights
    close(op.matvec(block), grid @ block)
    close(op.matvec(block.astype(np.float32)), grid @ block, 1e-5)  # float32: relative rounding ≈ 6e-8 × terms
    held = np.ones(op.n, dtype=bool)
    held[free] = False
    coarse, _, _ = galerkin(sp.csr_array(grid), op.node_shape, held)
    level = ElementLevel.coarse_of(op).to_csr()
    assert abs(coarse - level).max() <= ROUND * abs(coarse).max()
    b = np.where(held, 0.0, np.random.default_rng(2).standard_normal(op.n))
    mg = MultigridSolver(op, rtol=1e-10, coarsest=100)
    solution = mg.solve(b)
    assert np.linalg.norm(grid @ solution - b) <= 1e-10 * np.linalg.norm(b) and mg.iterations[-1] < 30


@pytest.mark.parametrize("faces", [FIXED, SCENARIO], ids=["fixed faces", "every node unknown"])
def test_weighted_products_the_projection_and_the_residual_gram_match(faces: list[FaceSpec]) -> None:
    assembled, free = lift(body(6, faces, False)), lift(body(6, faces, True))
    basis = np.random.default_rng(4).standard_normal((assembled.n, 5))
    values = {"fibre.k": 0.2, "fibre.c": 7e6}
    ea, eb = ScipyEngine(assembled), ScipyEngine(free)
    close(ea.capacity(values, basis), eb.capacity(values, basis))
    cap = as_voxel_terms([t.operator for t in free.capacity.terms])
    close(weighted_product(cap, [1.0, 2.0], basis[:, 0]), cap[0] @ basis[:, 0] + 2.0 * (cap[1] @ basis[:, 0]))
    close(ea.input_terms(), eb.input_terms())
    ra, rb = ReducedModel.from_system(assembled, basis), ReducedModel.from_system(free, basis)
    for group in ("conductance", "capacity", "load"):
        for ta, tb in zip(getattr(ra.projected, group).terms, getattr(rb.projected, group).terms, strict=True):
            close(np.asarray(ta.operator), np.asarray(tb.operator))
    for ta, tb in zip(ra.initial.terms, rb.initial.terms, strict=True):
        close(np.asarray(ta.operator), np.asarray(tb.operator))
    ops_a = [sp.csr_array(t.operator) for t in (*assembled.conductance.terms, *assembled.capacity.terms)]
    ops_b = [t.operator for t in (*free.conductance.terms, *free.capacity.terms)]
    ga = ResidualGram.of(0, ea.input_terms(), ops_a, basis, chunk=50)
    gb = ResidualGram.of(0, eb.input_terms(), ops_b, basis, chunk=50)
    close(ga.gram, gb.gram)


def test_matrix_free_lifting_is_the_assembled_lifting() -> None:
    """The harmonic extension by matrix-free multigrid equals the direct solve of K_ff ℓ_f = −K_fd ℓ_d to the
    solver's tolerance (1e-10 relative residual; ℓ is O(1))."""
    assembled, free = body(7, FIXED, False), body(7, FIXED, True)
    values = {"fibre.k": 0.5}
    reference = liftings(assembled, values)
    owner = free.fixed_owner()
    terms = as_voxel_terms([t.operator for t in free.conductance.terms])
    weights = [float(t.coefficient(free.values(values))) for t in free.conductance.terms]
    for i in range(reference.shape[1]):
        boundary = np.where(owner == i, 1.0, 0.0)
        ell = harmonic_extension(terms, weights, boundary, np.flatnonzero(owner < 0))
        assert np.abs(ell - reference[:, i]).max() < 1e-8


#: Round-off may move a model by at most this share of its own error against the full model.
ROUNDOFF_SHARE = 0.1


def full_truth(system: ThermalSystem, times: np.ndarray) -> tuple[np.ndarray, float]:
    """Outputs of the full model at ``times``, BDF2 at dt = 0.01 and 0.005 s extrapolated (Richardson, order 2),
    and the size of that extrapolation (an estimate of the truth's own time error, far above it)."""
    runs = []
    for dt in (0.01, 0.005):
        obs = simulate(replace(system, time=TimeGrid(float(times[-1]), dt)), {}, None)
        runs.append(obs.as_array()[[int(np.argmin(np.abs(obs.t - t))) for t in times]])
    return runs[1] + (runs[1] - runs[0]) / 3.0, float(np.abs(runs[1] - runs[0]).max()) / 3.0


@pytest.mark.parametrize("faces", [SCENARIO, HELD], ids=["h", "fixed"])
def test_krylov_model_is_the_same_on_matrix_free_terms(faces: list[FaceSpec]) -> None:
    """One parameter point (the box's centre: no greedy choice), the whole span kept, CHOLMOD solves on both: the
    Krylov models of the assembled and of the matrix-free system are the same model.  They differ by round-off
    (summation order in the products) amplified by the orthonormalisation of nearly dependent moments: measured
    8e-9 °C (h) and 3.3e-6 °C (fixed; numpy 2.4, scipy 1.17), machine-dependent.  What must hold everywhere is that
    this round-off is negligible against the models' own error: below ROUNDOFF_SHARE of the error each makes against
    the full model (BDF2, extrapolated in dt; measured 2.5-2.9e-4 °C for these one-point models)."""
    times = np.array([0.5, 2.0, 8.0, 20.0])
    reductor = KrylovReductor.over(BOX, max_points=1, solver="cholmod", dual=False)
    models = [reduce(body(7, faces, free), 200, method=reductor, cache=False) for free in (False, True)]
    assert models[0].order == models[1].order
    outputs = [m.simulate({}, times).as_array() for m in models]
    truth, time_error = full_truth(body(7, faces, False), times)
    errors = [float(np.abs(o - truth).max()) for o in outputs]
    assert min(errors) > 10 * time_error  # the models' error is measured, not the truth's
    assert float(np.abs(outputs[0] - outputs[1]).max()) <= ROUNDOFF_SHARE * min(errors), errors


def test_matrix_free_krylov_on_multigrid_is_as_accurate_as_the_assembled_one() -> None:
    """The greedy over the box (4 points) with multigrid solves (1e-10) on matrix-free terms against CHOLMOD on the
    assembled terms: at the reference and at the slow corner both models err alike against the exact full
    semi-discrete model (dense eigendecomposition)."""
    times = np.array([0.5, 2.0, 8.0, 20.0])
    models = [reduce(body(5, SCENARIO, free), 200, cache=False,
                     method=KrylovReductor.over(BOX, solver=solver, dual=False, max_points=4))
              for free, solver in ((False, "cholmod"), (True, "mg"))]
    assert models[1].info["solver"] == "mg"
    assembled = body(5, SCENARIO, False)
    for values in ({}, {"fibre.k": 0.1, "fibre.c": 1e7}):
        exact = exact_outputs(assembled, values, times)
        errors = [float(np.abs(m.simulate(values, times).as_array() - exact).max()) for m in models]
        assert errors[1] <= 2.0 * errors[0] + 1e-9 * float(np.abs(exact).max()), errors


def test_matrix_free_transient_is_the_assembled_transient() -> None:
    """BDF2 on multigrid (1e-8 per step, matrix-free) against BDF2 on CHOLMOD (assembled): the same steps."""
    assembled, free = body(9, SCENARIO, False), body(9, SCENARIO, True)
    values = {"fibre.k": 0.1, "fibre.c": 1e7}
    a = transient(assembled, values, np.arange(0.0, 3.01, 0.5), method="cholmod").as_array()
    b = transient(free, values, np.arange(0.0, 3.01, 0.5), method="mg").as_array()
    assert np.abs(a - b).max() < 1e-6 * np.ptp(a)


def test_fingerprint_tells_matrix_free_systems_apart() -> None:
    a, b = body(5, SCENARIO, True), body(5, SCENARIO, True)
    c = body(5, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=2.0)], True, (5, 5, 6))
    assert a.fingerprint() == b.fingerprint() != c.fingerprint()
    term = a.conductance.terms[0].operator
    assert isinstance(term, VoxelTerm) and term.restricted(np.arange(3)) is None


def test_krylov_reduction_of_a_large_voxel_scene_assembles_matrix_free_terms() -> None:
    """Above MATRIX_FREE_ABOVE nodes a voxel scene reduced by the Krylov method gets matrix-free terms; the amalgam
    and small scenes keep the assembled ones."""
    from aromm.reduction.offline import MATRIX_FREE_ABOVE, matrix_free_krylov
    from aromm.scene.reduction_section import ReductionSettings
    from aromm.studies.chavez2020 import loading, small_wood

    for n, method, expected in ((28, "krylov", True), (28, "aromm", False), (12, "krylov", False)):
        scene = loading(small_wood(n), "z")
        assert ((n + 1) ** 3 > MATRIX_FREE_ABOVE) == (n == 28)
        assert matrix_free_krylov(scene, ReductionSettings(method=method), references=False) is expected


def test_a_periodic_block_product_is_the_assembled_periodic_matrix_column_by_column() -> None:
    """Columns of a block share each slab's weights; ghosts of the periodic grid fold onto their twins per column."""
    phase = (np.random.default_rng(6).random((5, 4, 6)) < 0.4).astype(np.int8)
    op = VoxelOperator(phase, np.array([[0.03] * 3, [0.3, 0.5, 0.2]]), (1e-4, 1.2e-4, 0.9e-4), periodic=True)
    block = np.random.default_rng(7).standard_normal((op.n, 5))
    close(op.matvec(block), assembled_matrix(op) @ block)


def test_a_product_into_a_kept_vector_overwrites_it_and_bad_targets_are_refused() -> None:
    """``matvec(x, out=y)`` writes K x over whatever y held (the multigrid and the residual Gram reuse their arrays),
    for a vector and for a block with contiguous columns; a target of another shape, precision or layout, or one
    sharing memory with the input, is an InputError naming the expected array."""
    phase = (np.random.default_rng(8).random((4, 5, 3)) < 0.5).astype(np.int8)
    op = VoxelOperator(phase, np.array([[0.02] * 3, [0.4, 0.3, 0.6]]), (1e-4, 1e-4, 1.1e-4), fixed=("z0",),
                       capacity=np.array([1e5, 2e6]), exchange=(("z1", 12.0),))
    x = np.random.default_rng(9).standard_normal(op.n)
    out = np.full(op.n, np.nan)
    assert op.matvec(x, out=out) is not None
    close(out, assembled_matrix(op) @ x)
    out32 = np.full(op.n, 7.0, dtype=np.float32)
    op.matvec(x.astype(np.float32), out=out32)
    close(out32.astype(float), assembled_matrix(op) @ x.astype(np.float32).astype(float), tol=1e-5)
    basis = np.asfortranarray(np.random.default_rng(10).standard_normal((op.n + 7, 3)))
    rows = basis[2:op.n + 2]  # a row slice of a Fortran basis: contiguous columns, read in place
    block_out = np.full((op.n, 3), np.nan, order="F")
    assert op.matvec(rows, out=block_out) is block_out
    close(block_out, assembled_matrix(op) @ rows)
    for bad_x, bad_out in ((x, out32), (x, x), (np.column_stack([x, x]), out), (rows, np.zeros((op.n, 3))),
                           (rows, np.zeros((op.n, 2), order="F")), (rows, basis[:op.n])):
        with pytest.raises(InputError, match="out must be"):
            op.matvec(bad_x, out=bad_out)


def _csr(m: sp.csr_array | StencilMatrix) -> sp.csr_array:
    """A level's matrix in float64 CSR (the coarse levels but the last are coefficient arrays)."""
    return m.tocsr() if isinstance(m, StencilMatrix) else sp.csr_array(m, dtype=float)


def test_affine_coarse_levels_are_the_galerkin_levels_of_the_weighted_sum() -> None:
    """Levels stored per term and summed with the weights (fixed faces applied after) equal the Galerkin levels of
    K(μ) + s C(μ) + h H: the first against scipy's Pᵀ A P of the assembled sum (independent truth), every level
    against the solver's own coarsening; float32 storage within its rounding; the solver converges alike."""
    system = lift(body(0, FIXED, True, (17, 16, 18)))
    terms = as_voxel_terms([t.operator for t in (*system.conductance.terms, *system.capacity.terms)])
    weights = [0.7, 0.03, 25.0, 3e4, 2e5]
    op = shifted_operator(terms, weights)
    single = [shifted_operator([t], [1.0]) for t in terms]
    exact = AffineLevels.build(single, coarsest=100, dtype=np.float64).levels(weights, op.fixed)
    direct = galerkin_levels(op, 100, np.float64)
    assert len(exact) == len(direct) >= 2
    for a, b in zip(exact, direct, strict=True):
        assert a.node_shape == b.node_shape and a.fixed == b.fixed
        assert abs(_csr(a.matrix) - _csr(b.matrix)).max() <= ROUND * abs(_csr(b.matrix)).max()
    grid = assembled_matrix(op)
    held = np.ones(op.n, dtype=bool)
    held[terms[0].free] = False
    coarse, _, _ = galerkin(sp.csr_array(grid), op.node_shape, held)
    assert abs(coarse - _csr(exact[0].matrix)).max() <= ROUND * abs(coarse).max()
    stored = AffineLevels.build(single, coarsest=100)
    assert stored.nbytes > 0
    rounded = stored.levels(weights, op.fixed)
    assert abs(_csr(rounded[0].matrix) - _csr(exact[0].matrix)).max() <= 1e-6 * abs(coarse).max()
    b = np.where(held, 0.0, np.random.default_rng(2).standard_normal(op.n))
    plain, summed = MultigridSolver(op, rtol=1e-10, coarsest=100), MultigridSolver(op, rtol=1e-10, coarsest=100,
                                                                                    coarse=rounded)
    x = summed.solve(b)
    plain.solve(b)
    assert np.linalg.norm(grid @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert abs(summed.iterations[-1] - plain.iterations[-1]) <= 1
