"""Algebraic-multigrid V-cycle applied to many vectors at once (a preconditioner for block eigensolvers).

The hierarchy (operators ``A_l``, prolongations ``P_l``) is pyamg's smoothed aggregation
[VanekMandelBrezina1996]; the cycle is our own so that every step is a sparse × dense-block
product: on this machine one product of a 27-point voxel operator with 32 columns costs what
4.7 single products cost (measured at 64³, benchmarks/reduce_scaling.py), while pyamg's own
cycle (Gauss–Seidel smoothing) works one vector at a time.

Smoothing is a Chebyshev polynomial of degree ``degree`` in ``D⁻¹A`` on the interval
``[ρ/30, 1.1 ρ]`` (ρ: the largest eigenvalue of ``D⁻¹A``, estimated by power iteration), the same
polynomial before and after the coarse correction, so the cycle is a symmetric positive-definite
operator ``T ≈ A⁻¹`` [Adams2003]; the coarsest level is solved by a dense Cholesky factorisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray

#: Chebyshev smoothing interval ``[ρ / CHEBYSHEV_LOWER, CHEBYSHEV_UPPER ρ]``.
CHEBYSHEV_LOWER = 30.0
CHEBYSHEV_UPPER = 1.1
#: Power iterations for the largest eigenvalue of D⁻¹A on each level.
POWER_ITERATIONS = 15
#: Levels are coarsened until at most this many unknowns remain (dense Cholesky there).
COARSEST = 500


@dataclass(frozen=True)
class _Level:
    matrix: sp.csr_array
    inverse_diagonal: FloatArray
    rho: float
    prolongation: sp.csr_array | None


class BlockMultigrid:
    """``T(B) ≈ A⁻¹ B`` for a sparse SPD ``A`` and a block ``B`` (n,) or (n, m); one V-cycle per call.

    ``near_null`` (n × k) and ``blocksize``: the aggregation's candidate vectors and the unknowns per node (stored node
    by node) of a system of several fields, pyamg's ``B`` and BSR block size (default: the constant, scalar nodes);
    benchmarks/coupled_solvers.py measures them on the coupled heat–moisture operator."""

    def __init__(self, a: sp.sparray | sp.spmatrix, *, degree: int = 2, cycles: int = 1,
                 rng: np.random.Generator, near_null: FloatArray | None = None, blocksize: int = 1) -> None:
        import pyamg  # type: ignore[import-untyped]

        a = sp.csr_array(a)
        if a.shape[0] <= COARSEST:
            self.levels: list[_Level] = [_Level(a, np.ones(a.shape[0]), 1.0, None)]
        else:
            # 'local' Jacobi weighting of the prolongation smoother: pyamg's default estimates a spectral radius
            # from a random vector of numpy's global generator (not reproducible)
            fine = sp.csr_matrix(a) if blocksize == 1 else sp.bsr_matrix(a, blocksize=(blocksize, blocksize))
            ml = pyamg.smoothed_aggregation_solver(fine, B=near_null, symmetry="symmetric", max_coarse=COARSEST,
                                                   smooth=("jacobi", {"weighting": "local"}))
            self.levels = []
            for lev in ml.levels:
                mat = sp.csr_array(lev.A)
                diag = mat.diagonal()
                if np.any(diag <= 0):
                    raise NumericalError("block multigrid: a non-positive diagonal entry (matrix not SPD)")
                p = sp.csr_array(lev.P) if hasattr(lev, "P") else None
                self.levels.append(_Level(mat, 1.0 / diag, _largest_eigenvalue(mat, 1.0 / diag, rng), p))
        coarse = self.levels[-1].matrix.toarray()
        try:
            self._coarse = sla.cho_factor(coarse, lower=True)
        except np.linalg.LinAlgError:
            raise NumericalError("block multigrid: coarsest operator is not positive definite") from None
        self.degree = degree
        self.cycles = cycles
        self.shape = a.shape

    @property
    def nbytes(self) -> int:
        """Memory of the hierarchy below the fine operator (bytes): coarse operators, prolongations, vectors."""
        total = 0
        for i, lev in enumerate(self.levels):
            if i > 0:
                total += lev.matrix.data.nbytes + lev.matrix.indices.nbytes + lev.matrix.indptr.nbytes
            if lev.prolongation is not None:
                p = lev.prolongation
                total += p.data.nbytes + p.indices.nbytes + p.indptr.nbytes
            total += lev.inverse_diagonal.nbytes
        return total

    def __call__(self, b: FloatArray) -> FloatArray:
        """``cycles`` V-cycles as a stationary iteration from zero (a symmetric operator for any count)."""
        b = np.asarray(b, dtype=float)
        x = self._cycle(0, b)
        for _ in range(self.cycles - 1):
            x += self._cycle(0, b - self.levels[0].matrix @ x)
        return x

    def _cycle(self, i: int, b: FloatArray) -> FloatArray:
        lev = self.levels[i]
        if lev.prolongation is None:
            return np.asarray(sla.cho_solve(self._coarse, b))
        x = self._smooth(lev, b, None)
        r = b - lev.matrix @ x
        x += lev.prolongation @ self._cycle(i + 1, lev.prolongation.T @ r)
        return self._smooth(lev, b, x)

    def _smooth(self, lev: _Level, b: FloatArray, x: FloatArray | None) -> FloatArray:
        """Chebyshev iteration (degree ``self.degree``) on ``A x = b`` preconditioned by the diagonal."""
        upper, lower = CHEBYSHEV_UPPER * lev.rho, lev.rho / CHEBYSHEV_LOWER
        theta, delta = (upper + lower) / 2, (upper - lower) / 2
        sigma = theta / delta
        rho = 1.0 / sigma
        dinv = lev.inverse_diagonal if b.ndim == 1 else lev.inverse_diagonal[:, None]
        r = b.copy() if x is None else b - lev.matrix @ x
        d = dinv * r / theta
        x = d.copy() if x is None else x + d
        for _ in range(self.degree - 1):
            r -= lev.matrix @ d
            rho_new = 1.0 / (2 * sigma - rho)
            d *= rho_new * rho
            d += (2 * rho_new / delta) * (dinv * r)
            rho = rho_new
            x += d
        return x


def _largest_eigenvalue(a: sp.csr_array, inverse_diagonal: FloatArray, rng: np.random.Generator) -> float:
    """Power-iteration estimate of the largest eigenvalue of ``D⁻¹A`` (from below; the smoother widens it)."""
    x = rng.standard_normal(a.shape[0])
    rho = 1.0
    for _ in range(POWER_ITERATIONS):
        y = inverse_diagonal * (a @ x)
        rho = float(np.linalg.norm(y) / np.linalg.norm(x))
        x = y / np.linalg.norm(y)
    return rho
