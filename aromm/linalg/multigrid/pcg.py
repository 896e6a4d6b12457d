"""Conjugate gradients preconditioned by a geometric multigrid V-cycle on the voxel grid.

Levels: the matrix-free fine operator (:class:`~aromm.linalg.multigrid.operator.VoxelOperator`), then Galerkin
coarse operators as 27 coefficient arrays (:mod:`aromm.linalg.multigrid.hierarchy`,
:mod:`aromm.linalg.multigrid.coarse_stencil`; the coarsest in CSR) down to a grid of at most
``COARSEST_NODES`` nodes, solved directly (CHOLMOD, else SuperLU).  Smoother: Chebyshev polynomial of degree
``DEGREE`` in D⁻¹A on [λ/``SPREAD``, λ] with λ a Gershgorin bound of D⁻¹A, the same before and after the
coarse correction, so the V-cycle is a symmetric positive-definite preconditioner [Adams2003, § 3]
[Trottenberg2001, ch. 2]; trilinear transfers (:mod:`aromm.linalg.multigrid.transfer`).  Each level keeps its
V-cycle vectors and CG its own (three besides x and r: the step x += α p is BLAS's in-place daxpy), so a solve
maps no fresh fine-grid array per operation; :meth:`MultigridSolver.release` hands them back between solves.  CG
stops when the true relative residual ‖b − A x‖ / ‖b‖ ≤ ``rtol`` and raises
:class:`~aromm.core.errors.NumericalError` (naming the solver, the residual and the iteration count) otherwise.

A periodic operator is singular (constants): the right-hand side must sum to zero, the coarsest solve pins
one node and the preconditioned residual is kept mean-free, so CG runs in the range of A.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.linalg.blas import daxpy

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.linalg.factorizations import DEFAULT_RTOL, FLOOR_FACTOR, factorize_direct, resolve_method, rounding_floor
from aromm.linalg.multigrid.assembled import GridMatrix, galerkin
from aromm.linalg.multigrid.coarse_stencil import StencilMatrix
from aromm.linalg.multigrid.hierarchy import CoarseLevel, fixed_mask, galerkin_levels
from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.transfer import transfer

COARSEST_NODES = 4_000  # a 10³–16³ coarsest grid: its factorisation and solves were half of a 40³ solve at 20 000
DEGREE = 2
SPREAD = 8.0  # Chebyshev interval [λ/SPREAD, λ]: the upper part of the spectrum, which the coarse grid cannot see
MAX_ITERATIONS = 500
#: Gershgorin row ratio ``Σ_j abs(m_0j) / m_00`` of the Q1 face mass, (4 + 2 + 2 + 1)/4: bounds a convection face.
FACE_MASS_BOUND = 9.0 / 4.0
# V-cycle arithmetic: single halves its memory traffic; CG, its residuals and the stopping test stay float64
PRECISIONS: dict[str, type] = {"single": np.float32, "double": np.float64}
#: A level's vectors that are views of another's memory: in a V-cycle (MultigridSolver._vcycle) the prolongation's
#: passes run after the restriction's are consumed and before the post-smoother's first direction d is formed, so
#: they share memory (the fine level of a periodic grid: 7 bytes a voxel in float32).
SHARED = {"interpolate0": "restrict1", "interpolate1": "restrict0", "interpolate2": "d"}


class _Operator(Protocol):
    def __matmul__(self, x: FloatArray) -> FloatArray: ...


@dataclass(eq=False)
class _Level:
    """A grid level: operator, inverse diagonal, Gershgorin bound of D⁻¹A, transfer to the next coarser level."""

    matrix: _Operator
    inverse_diagonal: FloatArray
    lam: float
    shape: tuple[int, int, int]
    elements: tuple[int, int, int]  # (z, y, x) elements: the transfer to the next coarser level
    periodic: bool
    fixed: npt.NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    work: dict[str, FloatArray] = field(default_factory=dict)  # the V-cycle's vectors on this level, reused

    def vector(self, name: str, shape: tuple[int, ...], dtype: npt.DTypeLike) -> FloatArray:
        """The level's vector ``name`` (uninitialised), allocated once: a fresh fine-grid vector per use is a fresh
        mapping of up to 136 MB at 256³, which the kernel faults in page by page (operator.VoxelOperator.matvec).
        Names in ``SHARED`` are views of another vector's memory (never live at the same time)."""
        key, size = SHARED.get(name, name), int(np.prod(shape))
        v = self.work.get(key)
        if v is None or v.size < size or v.dtype != dtype:
            v = self.work[key] = np.empty(max(size, v.size if v is not None and v.dtype == dtype else 0), dtype)
        return v[:size].reshape(shape)


@dataclass(eq=False)
class MultigridSolver:
    """``solve(b)`` for the constrained voxel operator; ``iterations`` lists the CG count of every solve."""

    operator: VoxelOperator | GridMatrix
    rtol: float = DEFAULT_RTOL
    coarsest: int = COARSEST_NODES
    precision: str = "single"
    levels: list[_Level] = field(init=False)
    coarse_solve: object = field(init=False)
    iterations: list[int] = field(default_factory=list)
    at_floor: int = 0  # solves accepted at the rounding floor of the residual (FLOOR_FACTOR), above rtol
    _matrix: sp.csr_array | None = field(init=False, default=None)  # float64 operator of CG when assembled
    #: Galerkin levels shared by operators that differ only in their fixed faces (the fixed-temperature problems
    #: of the three axes): pass the same dict to each solver (CoarseLevel.with_fixed).
    shared: dict[str, list[CoarseLevel]] | None = None
    #: The coarse levels of ``operator`` (its fixed faces applied) when the caller has them, e.g. as a weighted sum
    #: of stored levels of an affine family (aromm.linalg.multigrid.affine_voxel); otherwise built here.
    coarse: list[CoarseLevel] | None = None

    def __post_init__(self) -> None:
        if not 0 < self.rtol < 1:
            raise InputError(f"multigrid: relative residual tolerance must lie in (0, 1), got {self.rtol:g}")
        if self.precision not in PRECISIONS:
            raise InputError(f"multigrid precision {self.precision!r}; allowed: {', '.join(PRECISIONS)}")
        dtype = PRECISIONS[self.precision]
        op = self.operator
        if not isinstance(op, VoxelOperator):
            self._assembled(op, dtype)
            return
        self.levels = [_Level(op, (1.0 / op.diagonal()).astype(dtype), _element_bound(op), op.node_shape,
                              op.elements, op.periodic)]
        coarse = self.coarse if self.coarse is not None else self._coarse_levels(op, dtype)
        for index, level in enumerate(coarse):
            matrix = level.matrix
            fixed = np.flatnonzero(fixed_mask(level.node_shape, level.fixed))
            if index == len(coarse) - 1:
                self.coarse_solve = _direct(matrix, op.periodic)
                self.levels.append(_Level(matrix, np.zeros(0), 0.0, level.node_shape, level.elements, op.periodic,
                                          fixed))
                return
            self.levels.append(_Level(matrix, (1.0 / matrix.diagonal()).astype(dtype), _row_bound(matrix),
                                      level.node_shape, level.elements, op.periodic, fixed))
        self.coarse_solve = None  # single level: Chebyshev-preconditioned CG only

    def _coarse_levels(self, op: VoxelOperator, dtype: type) -> list[CoarseLevel]:
        """Galerkin levels of ``op`` (in ``dtype`` but the coarsest); with ``shared``, those of its free operator
        (built once) constrained."""
        if self.shared is None:
            return galerkin_levels(op, self.coarsest, dtype)
        if "free" not in self.shared:
            self.shared["free"] = galerkin_levels(replace(op, fixed=()), self.coarsest, dtype)
        return [level.with_fixed(op.fixed) for level in self.shared["free"]]

    def _assembled(self, grid: GridMatrix, dtype: type) -> None:
        """Levels of an assembled grid matrix (aromm.linalg.multigrid.assembled): Galerkin products by scipy."""
        a, shape, fixed = grid.full(), grid.shape, grid.missing()
        self._matrix = a
        coarse = iter(grid.coarse) if grid.coarse else None  # precomputed Galerkin levels (affine operators)
        self.levels = []
        while True:
            elements = (shape[0] - 1, shape[1] - 1, shape[2] - 1)
            last = bool(self.levels) and not coarsenable(elements, a.shape[0], self.coarsest)
            if last or min(elements) < 4:  # coarsest (the fine grid itself if too small: then a direct solve)
                self.levels.append(_Level(a, np.zeros(0), 0.0, shape, elements, False, np.flatnonzero(fixed)))
                self.coarse_solve = _direct(a, periodic=False)
                return
            self.levels.append(_Level(a.astype(dtype), (1.0 / a.diagonal()).astype(dtype), _row_bound(a), shape,
                                      elements, False, np.flatnonzero(fixed)))
            a, shape, fixed = next(coarse) if coarse is not None else galerkin(a, shape, fixed)

    def precondition(self, r: FloatArray, out: FloatArray | None = None) -> FloatArray:
        """One V-cycle from a zero guess, in the solver's precision; the result in float64 (into ``out``).  ``r`` is
        read in its own precision (no rounded copy of it is kept)."""
        z = self._vcycle(0, r, np.dtype(PRECISIONS[self.precision]))
        if out is None:
            out = np.empty(r.shape)
        np.copyto(out, z)
        if self.operator.periodic:
            out -= out.mean()
        return out

    def _vcycle(self, index: int, b: FloatArray, dtype: np.dtype) -> FloatArray:
        """x ≈ A⁻¹ b on level ``index`` in ``dtype`` (b may be wider: read, never rounded into a copy)."""
        level = self.levels[index]
        if index == len(self.levels) - 1 and self.coarse_solve is not None:
            return self.coarse_solve(b.astype(float)).astype(dtype)  # type: ignore[operator]
        x = level.vector("x", b.shape, dtype)  # returned: the caller uses it before the next V-cycle
        x.fill(0.0)
        r = level.vector("r", b.shape, dtype)
        np.copyto(r, b, casting="same_kind")
        r = _smooth(level, x, r, want_residual=index + 1 < len(self.levels))
        if index + 1 == len(self.levels):
            return x
        coarse = self.levels[index + 1]
        rc = transfer(r, level.elements, level.periodic, True, level.vector)
        rc[coarse.fixed] = 0.0
        x += transfer(self._vcycle(index + 1, rc, dtype), level.elements, level.periodic, False, level.vector)
        residual = _product(level.matrix, x, r)  # r is free again once restricted
        np.subtract(b, residual, out=residual, casting="same_kind")
        _smooth(level, x, residual, want_residual=False)
        return x

    def release(self) -> None:
        """Drop every level's kept vectors (CG's among them): a caller that needs the memory between solves calls
        it; the next solve maps them afresh (the periodic cell problems of a 200³ medium: 126 instead of 166 B/voxel
        at the peak, no measurable CPU cost; benchmarks/cell_memory.py)."""
        for level in self.levels:
            level.work.clear()

    def solve(self, b: FloatArray, x0: FloatArray | None = None, energy_tol: float | None = None) -> FloatArray:
        """x with ‖b − A x‖ ≤ rtol ‖b‖ (true residual, checked); NumericalError otherwise.

        ``energy_tol`` (from a zero guess only): stop instead once the energy-norm error ‖x* − x‖²_A is below it,
        estimated by the Hestenes–Stiefel sum with delay one [StrakosTichy2002]: the last step's α rᵀz equals
        ‖x_k − x_{k−1}‖²_A and bounds ‖x* − x_{k−1}‖²_A from below; x_k, whose error is that of x_{k−1} times the
        V-cycle's energy contraction (≈ 0.01–0.1), is returned.  For b = A x*, bᵀx* − bᵀx = ‖x* − x‖²_A: a
        quadratic quantity (energy, heat flow) is then known to that absolute accuracy.
        """
        b = np.asarray(b, dtype=float)
        nb = float(np.linalg.norm(b))
        if nb == 0.0:
            self.iterations.append(0)
            return np.zeros_like(b)
        if energy_tol is not None and (x0 is not None or not energy_tol > 0):
            raise InputError(f"multigrid: an energy tolerance needs a zero initial guess and a positive value, "
                             f"got {energy_tol!r}")
        a: _Operator = self.operator if self._matrix is None else self._matrix  # type: ignore[assignment]
        r = self.levels[0].vector("cg_r", b.shape, float)
        if x0 is None:
            x = np.zeros_like(b)
            np.copyto(r, b)
        else:
            x = np.array(x0, dtype=float)
            np.subtract(b, _product(a, x, r), out=r)
        if x0 is not None and float(np.linalg.norm(r)) <= self.rtol * nb:  # the guess already solves it
            self.iterations.append(0)
            return x
        total = 0
        work = [self.levels[0].vector(f"cg{i}", b.shape, float) for i in range(3)]
        while True:
            x, r, its = pcg(a, self.precondition, x, r, target=self.rtol * nb, budget=MAX_ITERATIONS - total,
                             work=work, energy=energy_tol)
            total += its
            if energy_tol is not None and total < MAX_ITERATIONS:  # stopped by the energy estimate
                self.iterations.append(total)
                return x
            np.subtract(b, _product(a, x, r), out=r)  # the recursive residual drifts: restart from the true one
            res = float(np.linalg.norm(r)) / nb
            if not np.isfinite(res):
                raise NumericalError(f"multigrid-preconditioned CG: non-finite residual after {total} iterations")
            if res <= self.rtol or res <= self.rtol + self.floor(x, nb):
                self.at_floor += res > self.rtol
                self.iterations.append(total)
                return x
            if total >= MAX_ITERATIONS:
                raise NumericalError(f"multigrid-preconditioned CG: relative residual {res:.2e} after {total} "
                                     f"iterations, above the tolerance {self.rtol:.0e}")

    def floor(self, x: FloatArray, nb: float) -> float:
        """The relative residual below which float64 cannot certify a solve, ``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖``.

        On the matrix-free operator abs(A) is not at hand: ``abs(A) abs(x) ≈ λ D abs(x)`` with λ the Gershgorin bound
        of D⁻¹A (Σ_j abs(a_ij) ≤ λ a_ii) and x locally smooth, an estimate of the same size."""
        if nb == 0.0:
            return 0.0
        if self._matrix is None:
            fine = self.levels[0]
            magnitude = np.abs(x, out=fine.vector("cg2", x.shape, float))  # CG's q: free between its runs
            magnitude /= fine.inverse_diagonal
            magnitude *= fine.lam
            return FLOOR_FACTOR * float(np.finfo(float).eps) * float(np.linalg.norm(magnitude)) / nb
        return rounding_floor(self._matrix, x, nb)


def pcg(a: _Operator, m: Callable[[FloatArray, FloatArray], FloatArray], x: FloatArray, r: FloatArray, *,
         target: float, budget: int, work: list[FloatArray], energy: float | None = None
         ) -> tuple[FloatArray, FloatArray, int]:
    """CG on A x = b from x with r = b − A x, preconditioned by ``m(r, out=z)``; x and r updated in place (x, r
    contiguous float64).  ``work``: the three vectors z, p and q (the solver's kept ones); x ← x + α p is BLAS's
    daxpy, in place: no fourth vector, one pass."""
    z, p, q = work
    m(r, z)
    np.copyto(p, z)
    rz = float(r @ z)
    for it in range(1, budget + 1):
        _product(a, p, q)
        pq = float(p @ q)
        if not pq > 0:
            raise NumericalError(f"multigrid-preconditioned CG: pᵀAp = {pq:.3g} ≤ 0 at iteration {it} "
                                 "(operator not positive definite?)")
        alpha = rz / pq
        if daxpy(p, x, a=alpha) is not x:  # f2py writes a contiguous float64 y in place and returns it
            raise NumericalError("conjugate gradients: BLAS daxpy did not update x in place (x not contiguous "
                                 "float64?)")
        q *= alpha
        r -= q
        if energy is not None and alpha * rz <= energy:  # ‖x_it − x_it−1‖²_A (see MultigridSolver.solve)
            return x, r, it
        if energy is None and float(np.linalg.norm(r)) <= target:
            return x, r, it
        m(r, z)
        rz_new = float(r @ z)
        p *= rz_new / rz
        p += z
        rz = rz_new
    return x, r, budget


def _smooth(level: _Level, x: FloatArray, r: FloatArray, want_residual: bool) -> FloatArray:
    """Chebyshev smoothing of A x = b in place, r = b − A x given; returns the new residual if wanted."""
    upper = level.lam
    lower = upper / SPREAD
    theta, delta = (upper + lower) / 2, (upper - lower) / 2
    sigma = theta / delta
    rho = 1.0 / sigma
    d = level.vector("d", r.shape, r.dtype)
    np.multiply(level.inverse_diagonal, r, out=d)
    d *= 1.0 / theta
    product = level.vector("product", r.shape, r.dtype)
    for k in range(DEGREE):  # in place on x, r (the caller's own copy) and the level's d and product
        x += d
        if k == DEGREE - 1 and not want_residual:
            break
        _product(level.matrix, d, product)
        r -= product
        if k == DEGREE - 1:
            break
        rho_new = 1.0 / (2.0 * sigma - rho)
        d *= rho_new * rho
        np.multiply(level.inverse_diagonal, r, out=product)
        product *= 2.0 * rho_new / delta
        d += product
        rho = rho_new
    return r


def _product(matrix: _Operator, v: FloatArray, out: FloatArray) -> FloatArray:
    """``out`` ← A v: a matrix-free operator (``matvec(v, out=)``) writes into ``out``; an assembled (coarse) matrix's
    product is copied."""
    if not sp.issparse(matrix):
        return matrix.matvec(v, out=out)  # type: ignore[attr-defined]
    out[...] = matrix @ v
    return out


def coarsenable(elements: tuple[int, int, int], nodes: int, coarsest: int) -> bool:
    return nodes > coarsest and min(elements) >= 4


def _element_bound(op: VoxelOperator) -> float:
    """Gershgorin bound of D⁻¹A on the fine level: max over phases of Σ_j |K_e,0j| / K_e,00 (a mediant).

    From corner 0 of an element, node j's entry has class 0 (same end) or 1 (other end) along each axis.
    """
    values = op.class_values
    row = np.abs(values[:, :2, :2, :2]).sum(axis=(1, 2, 3))
    bound = float(np.max(row / values[:, 0, 0, 0]))
    return max(bound, FACE_MASS_BOUND) if op.exchange else bound


def _row_bound(matrix: sp.csr_array | StencilMatrix) -> float:
    """Gershgorin bound of D⁻¹A: max_i Σ_j |a_ij| / a_ii (rows are never empty: the diagonal is stored)."""
    if isinstance(matrix, StencilMatrix):
        row = matrix.abs_row_sums()
    else:
        row = np.add.reduceat(np.abs(matrix.data), matrix.indptr[:-1])
    return float(np.max(row / matrix.diagonal()))


def pinned(matrix: sp.csr_array) -> sp.csr_array:
    """A singular periodic operator with node 0's row and column replaced by the identity (T̃_0 = 0)."""
    keep = np.ones(matrix.shape[0])
    keep[0] = 0.0
    pin = sp.diags_array(keep)
    return sp.csr_array(pin @ matrix @ pin + sp.diags_array(1.0 - keep))


def _direct(matrix: sp.csr_array, periodic: bool) -> object:
    """Coarsest-grid solve; a periodic (singular) operator has node 0 pinned and mean-free right-hand sides."""
    factor = factorize_direct(pinned(matrix) if periodic else matrix, resolve_method("auto"))

    def solve(b: FloatArray) -> FloatArray:
        if not periodic:
            return factor.solve(b, check=False)
        rhs = b - b.mean()
        rhs[0] = 0.0
        return factor.solve(rhs, check=False)

    return solve


def grid_solver(a: sp.csr_array, points: FloatArray | None, rtol: float) -> Callable[[FloatArray], FloatArray]:
    """``solve(b)`` by multigrid-preconditioned CG for ``aromm.linalg.direct.factorize(method="mg")``."""
    grid = GridMatrix.from_points(a, points)
    mg = MultigridSolver(grid, rtol=rtol)  # type: ignore[arg-type]

    def solve_one(b: FloatArray) -> FloatArray:
        full = np.zeros(grid.n)
        full[grid.index] = b
        return mg.solve(full)[grid.index]

    def solve(b: FloatArray) -> FloatArray:
        if b.ndim == 1:
            return solve_one(b)
        return np.column_stack([solve_one(b[:, j]) for j in range(b.shape[1])])

    return solve
