"""Conjugate gradients preconditioned by an aggregation multigrid V-cycle, on the matrix-free finite-volume stencil.

Levels: the fine :class:`~aromm.fv.stencil.Stencil`, then its Galerkin operators under 2 × 2 × 2 aggregation
(:func:`aromm.fv.stencil.coarsen`; again 7-point stencils, so every level runs the same kernels) down to at most
``COARSEST_CELLS`` cells, solved directly.  Smoother: one red–black Gauss–Seidel sweep (red then black) before the
coarse correction and its reverse (black then red) after; the red half from the cycle's zero guess is b / d
(``first_sweep``), and the residual is restricted as it is computed (``residual_restrict``: no fine residual kept).
Piecewise-constant transfers make a coarse operator about twice too stiff for smooth errors [Braess1995]: the coarse
correction is scaled by ``SCALE``, and each coarse level is solved by ``CYCLES`` = 2 cycles (a W-cycle; CG
iterations on white-noise media of contrast 100 at 16³–128³: 28, 33, 35, 38, against 28, 38, 45, 58 with a V-cycle;
tests/test_fv_multigrid.py).  Each cycle is symmetric, a positive scale keeps the coarse correction positive
semi-definite, so the preconditioner is symmetric positive definite and plain CG applies.

A periodic stencil (:func:`aromm.fv.stencil.periodic_stencil`) with an odd axis cannot be coloured red–black (the
last and first cells of that axis are neighbours of one colour): such a level is smoothed by ``JACOBI_STEPS`` steps
of Jacobi damped by ``JACOBI_DAMPING`` before and after its coarse correction instead (symmetric, as each step is
self-adjoint in the energy product; its inverse diagonal is 8 more bytes per cell).  The coarsest periodic
operator, singular, is factorised with the first cell of every cluster held at zero.  CG then runs on the
consistent singular system: the right-hand side has no component in the null space (a divergence), so neither has
the residual, and the constants per cluster that the iterate picks up are irrelevant to the cell problem (it uses
the field's differences).

Memory, in bytes per cell of the fine grid: CG's x, r, z, p and q (float64, 40), the links (12, float32), the
live-cell byte (1), coarse levels (links, live byte, b, x and a W-cycle's residual and correction) ≈ (12 + 1 + 32) /
7 ≈ 6.4: ≈ 60 B in all (a level with an odd periodic axis adds its residual and Jacobi's diagonal, 16)
(:meth:`VolumeMultigrid.solve_hot_face`, which keeps no right-hand side; a general ``solve(b)`` adds b's 8;
benchmarks/fv_solver.py measures it).

CG stops when the true relative residual ``‖b − A x‖ / ‖b‖ ≤ rtol`` or at the rounding floor
``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖`` (:mod:`aromm.linalg.factorizations`), and raises
:class:`~aromm.core.errors.NumericalError` otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse import csgraph

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.fv.kernels import Kernels, kernels
from aromm.fv.stencil import Stencil, assembled, coarsen
from aromm.linalg.factorizations import DEFAULT_RTOL, FLOOR_FACTOR, factorize_direct
from aromm.linalg.multigrid.pcg import pcg

COARSEST_CELLS = 500  # a 5³–8³ coarsest grid; at 4,000 (12³–16³) a 46³ direction cost 0.026 CPU s, not 0.0225
SCALE = 1.8  # coarse-correction factor of piecewise-constant aggregation (module docstring)
MAX_ITERATIONS = 1_000
CYCLES = 2
#: Damped Jacobi on the levels with an odd periodic axis: steps before and after the coarse correction, and the
#: damping (≤ 1 keeps every step a contraction: the stencil's D⁻¹A has its spectrum in [0, 2], by Gershgorin).
JACOBI_STEPS = 2
JACOBI_DAMPING = 2.0 / 3.0


@dataclass(eq=False)
class _Level:
    stencil: Stencil
    alive: npt.NDArray[np.uint8]
    b: FloatArray
    x: FloatArray
    r: FloatArray
    e: FloatArray = field(default_factory=lambda: np.zeros(0))  # a W-cycle's residual and correction
    c: FloatArray = field(default_factory=lambda: np.zeros(0))
    jacobi: FloatArray = field(default_factory=lambda: np.zeros(0))  # damping × D⁻¹ (0: no equation); odd periodic


def cluster_heads(a: sp.csr_array) -> npt.NDArray[np.intp]:
    """The first unknown of every connected cluster of the graph of ``a``: one per constant in the null space of a
    conductance matrix without a fixed value.

    >>> cluster_heads(sp.csr_array(np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))).tolist()
    [0, 2]
    """
    _, cluster = csgraph.connected_components(a, directed=False)
    return np.unique(cluster, return_index=True)[1]


def _pinned(a: sp.csr_array) -> sp.csr_array:
    """``a`` with the first cell of every connected cluster held at zero (its row and column replaced by the
    identity's): a periodic operator's null space (a constant per cluster) removed, its solutions for a consistent
    right-hand side unchanged up to those constants."""
    keep = np.ones(a.shape[0])
    keep[cluster_heads(a)] = 0.0
    mask = sp.diags_array(keep)
    return sp.csr_array(mask @ a @ mask + sp.diags_array(1.0 - keep))


@dataclass(eq=False)
class StencilOperator:
    """``A`` of a stencil as the operator CG multiplies (``matvec(v, out=)`` and ``@``)."""

    stencil: Stencil
    ops: Kernels

    def matvec(self, v: FloatArray, out: FloatArray) -> FloatArray:
        """``out`` ← A v; v and out flat (CG's vectors) or of the stencil's shape."""
        shape = self.stencil.shape
        self.ops.product(self.stencil, v.reshape(shape), out.reshape(shape))
        return out

    def __matmul__(self, v: FloatArray) -> FloatArray:
        return self.matvec(v, np.empty_like(v))


@dataclass(eq=False)
class VolumeMultigrid:
    """``solve(b)`` of the stencil's ``A x = b``; ``iterations`` lists the CG count of every solve."""

    stencil: Stencil
    rtol: float = DEFAULT_RTOL
    backend: str = "auto"
    coarsest: int = COARSEST_CELLS
    iterations: list[int] = field(default_factory=list)
    at_floor: int = 0
    levels: list[_Level] = field(init=False)
    ops: Kernels = field(init=False)

    def __post_init__(self) -> None:
        if not 0 < self.rtol < 1:
            raise InputError(f"multigrid: relative residual tolerance must lie in (0, 1), got {self.rtol:g}")
        self.ops = kernels(self.backend)
        st = self.stencil
        self.levels = [self._level(st, np.zeros(0))]
        while st.cells > self.coarsest and min(st.shape) > 2:
            st = coarsen(st)
            self.levels.append(self._level(st, np.zeros(st.shape)))
        self._coarse_solve = factorize_direct(_pinned(assembled(st)) if st.periodic else assembled(st)) \
            if len(self.levels) > 1 else None

    def _level(self, st: Stencil, empty: FloatArray) -> _Level:
        """A level's data; the inverse diagonal of Jacobi where an odd periodic axis forbids red–black sweeps."""
        level = _Level(st, st.alive(), empty, empty.copy(), np.zeros(0))
        if st.periodic and any(n % 2 for n in st.shape):
            diagonal = np.empty(st.shape)
            self.ops.diagonal(st, diagonal)
            level.jacobi = np.divide(JACOBI_DAMPING, diagonal, out=np.zeros(st.shape), where=diagonal > 0)
        return level

    def nbytes(self) -> int:
        """Bytes the hierarchy keeps (links, live bytes, coarse vectors, Jacobi's diagonal), without CG's vectors."""
        return sum(lv.stencil.nbytes() + lv.alive.nbytes
                   + sum(v.nbytes for v in (lv.b, lv.x, lv.r, lv.e, lv.c, lv.jacobi)) for lv in self.levels)

    def precondition(self, r: FloatArray, z: FloatArray) -> FloatArray:
        """One V-cycle from a zero guess: ``z ≈ A⁻¹ r`` (flat or of the stencil's shape)."""
        shape = self.stencil.shape
        self._vcycle(0, r.reshape(shape), z.reshape(shape))
        return z

    def _vcycle(self, index: int, b: FloatArray, x: FloatArray) -> None:
        level, ops = self.levels[index], self.ops
        if index == len(self.levels) - 1 and self._coarse_solve is not None:
            x[...] = self._coarse_solve.solve(b.ravel(), check=False).reshape(x.shape)
            return
        self._smooth(level, b, x, 0, zero=True)
        if index + 1 < len(self.levels):
            coarse = self.levels[index + 1]
            ops.residual_restrict(level.stencil, b, x, coarse.b)
            self._coarse_correction(index + 1)
            ops.prolong(coarse.x, x, level.alive, SCALE)
        self._smooth(level, b, x, 1)

    def _smooth(self, level: _Level, b: FloatArray, x: FloatArray, first: int, zero: bool = False) -> None:
        """Red–black Gauss–Seidel, colour ``first`` then the other, or damped Jacobi on a level with an odd
        periodic axis (its residual in the level's ``r``, allocated at the first use); ``zero``: from x = 0 (x's
        values unread)."""
        if not level.jacobi.size:
            (self.ops.first_sweep if zero else self.ops.sweep)(level.stencil, b, x, first)
            self.ops.sweep(level.stencil, b, x, 1 - first)
            return
        if zero:
            x.fill(0.0)
        if level.r.size != x.size:
            level.r = np.empty(x.shape)
        r = level.r.reshape(x.shape)
        for _ in range(JACOBI_STEPS):
            self.ops.residual(level.stencil, b, x, r)
            r *= level.jacobi
            x += r

    def _coarse_correction(self, index: int) -> None:
        """``x ≈ A⁻¹ b`` on level ``index``: one cycle, or ``CYCLES`` (a W-cycle) below the fine grid's first
        coarsening, each from the last one's residual."""
        level = self.levels[index]
        self._vcycle(index, level.b, level.x)
        if index == len(self.levels) - 1 or CYCLES == 1:
            return
        if not level.e.size:
            level.e, level.c = np.empty_like(level.x), np.empty_like(level.x)
        for _ in range(CYCLES - 1):
            self.ops.residual(level.stencil, level.b, level.x, level.e)
            self._vcycle(index, level.e, level.c)
            level.x += level.c

    def floor(self, x: FloatArray, nb: float, work: tuple[FloatArray, FloatArray, FloatArray]) -> float:
        """``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖``, with ``abs(A) abs(x) = 2 D abs(x) − A abs(x)`` (A = D − N,
        N ≥ 0); ``work``: three free vectors."""
        shape = self.stencil.shape
        ax, out, product = (w.reshape(shape) for w in work)
        np.abs(x.reshape(shape), out=ax)
        self.ops.diagonal(self.stencil, out)
        out *= ax
        out *= 2.0
        self.ops.product(self.stencil, ax, product)
        out -= product
        return FLOOR_FACTOR * float(np.finfo(float).eps) * float(np.linalg.norm(out)) / nb

    def solve(self, b: FloatArray) -> FloatArray:
        """x with ‖b − A x‖ ≤ rtol ‖b‖ (true residual, checked), or at the rounding floor; NumericalError
        otherwise."""
        shape = self.stencil.shape

        def true_residual(x: FloatArray, r: FloatArray) -> None:
            self.ops.residual(self.stencil, b.reshape(shape), x.reshape(shape), r.reshape(shape))

        return self._solve(float(np.linalg.norm(b)), true_residual)

    def solve_hot_face(self) -> FloatArray:
        """The field's homogenisation problem, T = 1 at the first face of the stencil's axis and 0 at the last:
        ``b = f`` on the first plane, zero elsewhere, never stored as a full array."""
        shape, st = self.stencil.shape, self.stencil

        def true_residual(x: FloatArray, r: FloatArray) -> None:
            self.ops.product(st, x.reshape(shape), r.reshape(shape))
            np.negative(r, out=r)
            np.moveaxis(r.reshape(shape), st.axis, 0)[0] += st.low

        return self._solve(float(np.linalg.norm(st.low)), true_residual)

    def _solve(self, nb: float, true_residual: Callable[[FloatArray, FloatArray], None]) -> FloatArray:
        """CG from x = 0; ``true_residual(x, r)`` writes b − A x into r (flat vectors)."""
        shape = self.stencil.shape
        x = np.zeros(self.stencil.cells)
        if nb == 0.0:
            self.iterations.append(0)
            return x.reshape(shape)
        a = StencilOperator(self.stencil, self.ops)
        r = np.empty_like(x)
        true_residual(x, r)
        work = [np.empty_like(x) for _ in range(3)]
        total = 0
        while True:
            x, r, its = pcg(a, self.precondition, x, r, target=self.rtol * nb, budget=MAX_ITERATIONS - total,
                            work=work)
            total += its
            true_residual(x, r)  # the recursive residual drifts: restart from the true one
            res = float(np.linalg.norm(r)) / nb
            if not np.isfinite(res):
                raise NumericalError(f"finite-volume multigrid CG: non-finite residual after {total} iterations")
            if res <= self.rtol or res <= self.rtol + self.floor(x, nb, (work[0], work[1], work[2])):
                self.at_floor += res > self.rtol
                self.iterations.append(total)
                return x.reshape(shape)
            if total >= MAX_ITERATIONS:
                raise NumericalError(f"finite-volume multigrid CG: relative residual {res:.2e} after {total} "
                                     f"iterations, above the tolerance {self.rtol:.0e}")

