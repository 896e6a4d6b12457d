"""A pyMOR linear solver backed by aromm.linalg.direct, so that pyMOR's reductors get the same sparse direct solver
as aromm (CHOLMOD with geometric nested dissection) instead of SuperLU with COLAMD.

pyMOR factorises a new matrix ``A + pE`` for every shift p of its low-rank ADI (Gramians) and IRKA.  With
real shifts on this symmetric pencil the matrix is symmetric definite (of either sign): CHOLMOD factorises
±matrix.  Complex or indefinite matrices go to SuperLU in the same nested-dissection order.  The last
factorisations are kept (keyed by the matrix object) for repeated solves with one matrix.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from pymor.bindings.scipy import ScipyLinearSolver

from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray
from aromm.linalg.direct import factorize
from aromm.linalg.orderings import nested_dissection

_KEEP = 2


class NestedDissectionSolver(ScipyLinearSolver):
    """``solve(matrix, V)`` with aromm's factorisations; ``points`` (n × 3) order the unknowns."""

    def __init__(self, points: FloatArray) -> None:
        super().__init__(check_finite=True)
        self.points = points
        self._factors: OrderedDict[int, tuple[Any, Any]] = OrderedDict()

    def _factor(self, matrix: Any) -> Any:
        key = id(matrix)
        if key in self._factors:
            return self._factors[key][1]
        a = sp.csr_array(matrix)
        solve = None
        if not np.iscomplexobj(a.data):
            sign = -1.0 if a.diagonal().max() < 0 else 1.0
            try:
                fac = factorize(sign * a, "cholmod", points=self.points)

                def solve(b: Any, fac: Any = fac, sign: float = sign) -> Any:
                    return sign * fac.solve(b, check=False)
            except NumericalError:
                solve = None
        if solve is None:
            perm = nested_dissection(a, self.points)
            inverse = np.argsort(perm)
            lu = spla.splu(sp.csc_matrix(a[perm][:, perm]), permc_spec="NATURAL")

            def solve(b: Any, lu: Any = lu, perm: Any = perm, inverse: Any = inverse) -> Any:
                return lu.solve(b[perm])[inverse]
        self._factors[key] = (matrix, solve)  # keep the matrix alive so that its id stays unique
        while len(self._factors) > _KEEP:
            self._factors.popitem(last=False)
        return solve

    def _solve_impl(self, matrix: Any, V: Any, initial_guess: Any, promoted_type: Any) -> Any:
        solve = self._factor(matrix)
        rhs = np.asarray(V)
        out = np.column_stack([solve(rhs[:, j].astype(promoted_type)) for j in range(rhs.shape[1])])
        return out.astype(promoted_type, copy=False)
