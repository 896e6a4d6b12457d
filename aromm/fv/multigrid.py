"""Conjugate gradients preconditioned by an aggregation multigrid V-cycle, on the matrix-free finite-volume stencil.

Levels: the fine :class:`~aromm.fv.stencil.Stencil`, then its Galerkin operators under 2 × 2 × 2 aggregation
(:func:`aromm.fv.stencil.coarsen`; again 7-point stencils, so every level runs the same kernels) down to at most
``COARSEST_CELLS`` cells, solved directly.  Smoother: one red–black Gauss–Seidel sweep (red then black) before the
coarse correction and its reverse (black then red) after.  Piecewise-constant transfers make a coarse operator about
twice too stiff for smooth errors [Braess1995]: the coarse correction is scaled by ``SCALE``, and each coarse level
is solved by ``CYCLES`` = 2 cycles (a W-cycle; CG iterations on white-noise media of contrast 100 at 16³–128³:
28, 33, 35, 38, against 28, 38, 45, 58 with a V-cycle; tests/test_fv_multigrid.py).  Each cycle is symmetric, a
positive scale keeps the coarse correction positive semi-definite, so the preconditioner is symmetric positive
definite and plain CG applies.

Memory, in bytes per cell of the fine grid: CG's x, r, z, p, q and step and the right-hand side (float64, 56), the
V-cycle's residual (8), the links (12, float32), the live-cell byte (1), coarse levels ≈ (12 + 1 + 40) / 7 ≈ 7.6:
≈ 85 B in all (measured in benchmarks/fv_solver.py).

CG stops when the true relative residual ``‖b − A x‖ / ‖b‖ ≤ rtol`` or at the rounding floor
``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖`` (:mod:`aromm.linalg.factorizations`), and raises
:class:`~aromm.core.errors.NumericalError` otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.fv.kernels import Kernels, kernels
from aromm.fv.stencil import Stencil, assembled, coarsen
from aromm.linalg.factorizations import DEFAULT_RTOL, FLOOR_FACTOR, factorize_direct
from aromm.linalg.multigrid.pcg import pcg

COARSEST_CELLS = 4_000
SCALE = 1.8  # coarse-correction factor of piecewise-constant aggregation (module docstring)
MAX_ITERATIONS = 1_000
CYCLES = 2


@dataclass(eq=False)
class _Level:
    stencil: Stencil
    alive: npt.NDArray[np.uint8]
    b: FloatArray
    x: FloatArray
    r: FloatArray
    e: FloatArray = field(default_factory=lambda: np.zeros(0))  # a W-cycle's residual and correction
    c: FloatArray = field(default_factory=lambda: np.zeros(0))


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
        self.levels = [_Level(st, st.alive(), *(np.zeros(0) for _ in range(3)))]
        while st.cells > self.coarsest and min(st.shape) > 2:
            st = coarsen(st)
            self.levels.append(_Level(st, st.alive(), *(np.zeros(st.shape) for _ in range(3))))
        self._coarse_solve = factorize_direct(assembled(st)) if len(self.levels) > 1 else None

    def nbytes(self) -> int:
        """Bytes the hierarchy keeps (links, live bytes, coarse vectors), without CG's vectors."""
        return sum(lv.stencil.nbytes() + lv.alive.nbytes + sum(v.nbytes for v in (lv.b, lv.x, lv.r, lv.e, lv.c))
                   for lv in self.levels)

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
        x.fill(0.0)
        ops.sweep(level.stencil, b, x, 0)
        ops.sweep(level.stencil, b, x, 1)
        if index + 1 < len(self.levels):
            coarse = self.levels[index + 1]
            r = level.r if index else self._fine_residual(x)
            ops.residual(level.stencil, b, x, r)
            ops.restrict(r, coarse.b)
            self._coarse_correction(index + 1)
            ops.prolong(coarse.x, x, level.alive, SCALE)
        ops.sweep(level.stencil, b, x, 1)
        ops.sweep(level.stencil, b, x, 0)

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

    def _fine_residual(self, like: FloatArray) -> FloatArray:
        fine = self.levels[0]
        if fine.r.shape != like.shape:
            fine.r = np.empty_like(like)
        return fine.r

    def floor(self, x: FloatArray, nb: float, work: FloatArray) -> float:
        """``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖``, with ``abs(A) abs(x) = 2 D abs(x) − A abs(x)`` (A = D − N,
        N ≥ 0)."""
        ax = np.abs(x).reshape(self.stencil.shape)
        work = work.reshape(ax.shape)
        self.ops.diagonal(self.stencil, work)
        work *= 2.0 * ax
        product = np.empty_like(ax)
        self.ops.product(self.stencil, ax, product)
        work -= product
        return FLOOR_FACTOR * float(np.finfo(float).eps) * float(np.linalg.norm(work)) / nb

    def solve(self, b: FloatArray) -> FloatArray:
        """x with ‖b − A x‖ ≤ rtol ‖b‖ (true residual, checked), or at the rounding floor; NumericalError
        otherwise."""
        shape = self.stencil.shape
        nb = float(np.linalg.norm(b))
        x = np.zeros(self.stencil.cells)
        if nb == 0.0:
            self.iterations.append(0)
            return x.reshape(shape)
        a = StencilOperator(self.stencil, self.ops)
        r = b.astype(float).ravel()  # CG's vectors are flat (views of the same memory as the stencil's shape)
        work = [np.empty_like(x) for _ in range(4)]
        total = 0
        while True:
            x, r, its = pcg(a, self.precondition, x, r, target=self.rtol * nb, budget=MAX_ITERATIONS - total,
                            work=work)
            total += its
            # the recursive residual drifts: restart from the true one
            self.ops.residual(self.stencil, b.reshape(shape), x.reshape(shape), r.reshape(shape))
            res = float(np.linalg.norm(r)) / nb
            if not np.isfinite(res):
                raise NumericalError(f"finite-volume multigrid CG: non-finite residual after {total} iterations")
            if res <= self.rtol or res <= self.rtol + self.floor(x, nb, work[0]):
                self.at_floor += res > self.rtol
                self.iterations.append(total)
                return x.reshape(shape)
            if total >= MAX_ITERATIONS:
                raise NumericalError(f"finite-volume multigrid CG: relative residual {res:.2e} after {total} "
                                     f"iterations, above the tolerance {self.rtol:.0e}")

