"""The growing basis of the offline reductions (aromm.reduction.column_buffer) and the block steps of the Krylov moments
(aromm.reduction.krylov: dependent right-hand sides solved once; aromm.reduction.scipy_engine: block orthonormalisation
in the capacity product), against plain NumPy and against the column-by-column algorithm."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
import scipy.sparse as sp
from test_krylov import two_phase

from aromm.reduction.column_buffer import (
    FIRST,
    MOST_RESERVED,
    ColumnBuffer,
    GrowingProjection,
    reservable_columns,
    reservation_budget,
)
from aromm.reduction.krylov import galerkin_guess, independent_columns
from aromm.reduction.rom import ReducedModel
from aromm.reduction.scipy_engine import ScipyEngine


def test_columns_are_appended_in_place_and_survive_growth() -> None:
    rng = np.random.default_rng(0)
    columns = ColumnBuffer(rows=50, reserve=FIRST)
    blocks = [rng.standard_normal((50, k)) for k in (1, 5, FIRST, 3)]
    basis = None
    for block in blocks:
        before = basis
        basis = columns.append(basis, block)
        if before is not None and before.shape[1] + block.shape[1] <= FIRST:
            assert np.shares_memory(before, basis)  # written after the previous view, no copy
    np.testing.assert_array_equal(basis, np.hstack(blocks))  # the growth past FIRST columns copied every column
    assert basis.flags.f_contiguous


def test_a_basis_within_the_reservation_never_moves() -> None:
    """Appending up to the reserved width writes after the previous view every time: no growth, so no moment where
    an old and a new buffer are both held (what ran a 256³ build out of memory at its 65th column)."""
    rng = np.random.default_rng(4)
    columns = ColumnBuffer(rows=30, reserve=3 * FIRST)
    first = basis = columns.append(None, rng.standard_normal((30, 4)))
    blocks = [np.asarray(first).copy()]
    while basis.shape[1] + 4 <= 3 * FIRST:
        block = rng.standard_normal((30, 4))
        blocks.append(block)
        basis = columns.append(basis, block)
        assert basis.ctypes.data == first.ctypes.data  # same memory: never copied
    np.testing.assert_array_equal(basis, np.hstack(blocks))


def test_the_reservation_spans_a_share_of_the_memory_within_bounds() -> None:
    rows_256, memory = 257**3, 24 * 2**30
    spanned = reservable_columns(rows_256, reservation_budget(memory, None)) * 8 * rows_256
    assert 0.7 * memory < spanned <= 0.75 * memory  # the share of the memory, in whole columns
    assert spanned // (8 * rows_256) > 64 + 8  # a 256³ span (≈ 60 columns) fits with a point's room
    assert reservable_columns(10, memory) == MOST_RESERVED
    assert reservable_columns(10**12, memory) == FIRST
    assert reservable_columns(100, None) == FIRST
    # under an address-space limit, half of what is left: 10 GB left at 128³ → 5 GB, 296 → capped
    assert reservation_budget(memory, 10 * 10**9) == 5 * 10**9
    assert reservation_budget(None, None) is None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc/self/statm are Linux's")
def test_under_an_address_space_limit_the_reservation_leaves_room() -> None:
    """With ``ulimit -v`` 3 GB above what the process uses, a basis of 1e6 rows reserves at most half of those
    3 GB, and a 1 GB array can still be allocated beside it (a 128³ series ran out of addresses when the
    reservation took 8.6 GB under a 10 GB limit)."""
    code = textwrap.dedent("""
        import os, resource
        import numpy as np
        from aromm.reduction.column_buffer import ColumnBuffer
        used = int(open("/proc/self/statm").read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        resource.setrlimit(resource.RLIMIT_AS, (used + 3 * 2**30, resource.RLIM_INFINITY))
        columns = ColumnBuffer(rows=10**6)
        columns.append(None, np.ones((10**6, 1)))
        other = np.ones(2**27)  # 1 GiB
        print(columns.reserve, int(other.sum()))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert FIRST <= int(out[0]) <= 1.5 * 2**30 / 8e6 and int(out[1]) == 2**27


def test_an_older_view_is_copied_not_written_over() -> None:
    columns = ColumnBuffer(rows=4)
    v = columns.append(None, np.ones((4, 1)))
    w = columns.append(v, np.full((4, 1), 2.0))
    u = columns.append(v, np.full((4, 1), 3.0))  # v is not the latest view: w's second column must stay 2
    np.testing.assert_array_equal(w[:, 1], 2.0)
    np.testing.assert_array_equal(u[:, 1], 3.0)


def test_the_final_combination_is_written_over_the_basis() -> None:
    rng = np.random.default_rng(1)
    columns = ColumnBuffer(rows=200_001)
    basis = columns.append(None, rng.standard_normal((200_001, 7)))
    coefficients = rng.standard_normal((7, 4))
    expected = basis @ coefficients
    out = columns.combine_in_place(basis, coefficients, chunk=65_536)
    assert np.shares_memory(out, basis)
    np.testing.assert_allclose(out, expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())


def test_dependent_right_hand_sides_are_found_from_their_explicit_remainders() -> None:
    system = two_phase(4, 10.0)
    engine = ScipyEngine(system)
    rng = np.random.default_rng(2)
    a, b = rng.standard_normal((system.n, 1)), rng.standard_normal((system.n, 1))
    assert independent_columns(engine, np.hstack([a, 3 * a, b]), 1e-10).tolist() == [0, 2]
    assert independent_columns(engine, np.hstack([a, b, a - 2 * b]), 1e-10).tolist() == [0, 1]
    assert independent_columns(engine, np.hstack([a, a + 1e-6 * b]), 1e-10).tolist() == [0, 1]
    # the flux load on z0 and the mean temperature of z0 are one vector up to a factor: one solve for both
    f = np.column_stack([np.asarray(t.operator) for t in system.load.terms if np.any(np.asarray(t.operator))])
    assert independent_columns(engine, np.hstack([f[:, :1], engine.output_block()]), 1e-10).tolist() == [0, 2]


def test_a_block_keeps_the_directions_the_column_by_column_algorithm_keeps() -> None:
    """Columns whose parts outside the basis are all small (1e-6) and differ by 1e-12: one new direction, as
    column by column (the relative eigenvalue threshold of the block's Gram matrix kept the 1e-12 one)."""
    system = two_phase(4, 10.0)
    engine = ScipyEngine(system)
    mu = dict(system.parameters)
    rng = np.random.default_rng(3)
    basis, _ = engine.orthonormalise(None, rng.standard_normal((system.n, 3)), mu, 1e-10)
    y, z = rng.standard_normal((system.n, 1)), rng.standard_normal((system.n, 1))
    inside = basis @ rng.standard_normal((3, 1))
    block = np.hstack([inside + 1e-6 * y, inside + 1e-6 * y + 1e-12 * z])
    sequential = np.array(basis)
    for j in range(2):
        sequential = np.array(engine.orthonormalise(sequential, block[:, j:j + 1], mu, 1e-10)[0])
    together, added = engine.orthonormalise(np.array(basis), block, mu, 1e-10)
    assert added == 1 and together.shape[1] == sequential.shape[1] == 4
    c = sp.csr_array(system.capacity.evaluate(system.values(mu)))
    np.testing.assert_allclose(together.T @ (c @ together), np.eye(4), atol=1e-12)


def test_the_projection_grown_with_the_basis_equals_a_fresh_one() -> None:
    """ScipyEngine.project on a basis that extends the last one projects only the new columns; the result equals
    the projection of the whole basis from scratch (the square terms are symmetric)."""
    system = two_phase(4, 1e3)
    engine = ScipyEngine(system)
    mu = dict(system.parameters)
    rng = np.random.default_rng(4)
    basis, _ = engine.orthonormalise(None, rng.standard_normal((system.n, 5)), mu, 1e-10)
    engine.project(basis)
    basis, _ = engine.orthonormalise(basis, rng.standard_normal((system.n, 4)), mu, 1e-10)
    grown = engine.project(basis).projected
    fresh = ReducedModel.from_system(system, np.array(basis)).projected
    for a, b in ((grown.conductance, fresh.conductance), (grown.capacity, fresh.capacity)):
        for ta, tb in zip(a.terms, b.terms, strict=True):
            scale = np.abs(tb.operator).max()
            np.testing.assert_allclose(ta.operator, tb.operator, rtol=0, atol=1e-12 * scale)


def test_the_galerkin_guess_is_exact_on_the_span_and_saves_cg_iterations() -> None:
    """The initial guess of the shifted solves, V (VᵀAV)⁻¹ Vᵀ b, returns A⁻¹ b exactly when it lies in span V (a
    Galerkin projection reproduces its subspace); on the multigrid solver a guess from the solutions at four nearby
    shifts (rational interpolation of A⁻¹ b in s) meets the same true residual rtol ‖b‖ in fewer CG iterations,
    and an exact guess in none."""
    system = two_phase(12, 1e3)
    engine = ScipyEngine(system, solver="mg")
    mu, shift, rtol = dict(system.parameters), 0.5, 1e-10
    values = system.values(mu)
    a = sp.csr_array(system.conductance.evaluate(values) + shift * system.capacity.evaluate(values))
    rng = np.random.default_rng(5)
    basis, _ = engine.orthonormalise(None, rng.standard_normal((system.n, 6)), mu, 1e-10)
    inside = basis @ rng.standard_normal((basis.shape[1], 2))
    np.testing.assert_allclose(galerkin_guess(engine, basis, mu, shift)(a @ inside), inside, rtol=0,
                               atol=1e-9 * np.abs(inside).max())
    pencil = engine.reduced_operator(basis, mu, shift)  # from the growing projection, not from a (K + sC) matrix
    np.testing.assert_allclose(pencil, basis.T @ (a @ basis), rtol=0, atol=1e-12 * np.abs(pencil).max())
    assert galerkin_guess(ScipyEngine(system, solver="splu"), basis, mu, shift)(a @ inside) is None

    b = engine.inputs(mu)[:, :1]
    cold = engine.shifted_solve(mu, shift, b, rtol)
    near = np.hstack([engine.shifted_solve(mu, f * shift, b, rtol) for f in (0.5, 0.8, 1.25, 2.0)])
    basis, _ = engine.orthonormalise(basis, near, mu, 1e-10)
    warm = engine.shifted_solve(mu, shift, b, rtol, galerkin_guess(engine, basis, mu, shift)(b))
    exact = engine.shifted_solve(mu, shift, b, rtol, cold)
    its = engine.stats.iterations
    assert its[5] <= its[0] - 3 and its[6] == 0, its  # measured 11 and 0 against 16
    for x in (cold, warm):
        assert np.linalg.norm(a @ x[:, 0] - b[:, 0]) <= rtol * np.linalg.norm(b) * 1.01
    np.testing.assert_array_equal(exact, cold)


def test_a_basis_written_over_in_place_is_projected_afresh() -> None:
    """GrowingProjection reuses VᵀAV only for a basis that extends the last one: after the buffer's columns are
    written over (the compression Ψ = V Q, same width) the projection is that of the new columns, not the stale one."""
    rng = np.random.default_rng(6)
    m = rng.standard_normal((6, 6))
    a = m + m.T
    columns = ColumnBuffer(rows=6)
    grown = GrowingProjection([a], lambda op, x: op @ x, lambda x, y: x.T @ y)
    v = columns.append(None, rng.standard_normal((6, 3)))
    grown.memo(columns, v)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    w = columns.combine_in_place(v, q)
    np.testing.assert_allclose(grown.memo(columns, w)[id(a)], w.T @ a @ w, rtol=1e-12, atol=1e-12)
