"""Sparse symmetric positive-definite solves by name: :func:`factorize`.

The direct factorisations (CHOLMOD, SuperLU) and pyamg's CG are :mod:`aromm.linalg.factorizations`; ``"mg"``, the
geometric multigrid-preconditioned CG on the voxel node grid read off ``points``, is
:func:`aromm.linalg.multigrid.pcg.grid_solver`.  This module puts them behind one name (the multigrid's coarse grid
is itself a direct factorisation, so the factorisations live below both).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.linalg.factorizations import (
    DEFAULT_RTOL,
    METHODS,
    Factorization,
    Method,
    check_residual,
    cholmod_available,
    factorize_direct,
    resolve_method,
)
from aromm.linalg.multigrid.pcg import grid_solver

__all__ = ["DEFAULT_RTOL", "METHODS", "Factorization", "Method", "check_residual", "cholmod_available", "factorize",
           "resolve_method"]


def factorize(a: sp.spmatrix | sp.sparray, method: str = "auto", rtol: float = DEFAULT_RTOL,
              points: FloatArray | None = None, ordering: npt.NDArray[np.int64] | None = None) -> Factorization:
    """A sparse SPD matrix prepared once for repeated solves by ``method`` (:data:`METHODS`):
    :func:`~aromm.linalg.factorizations.factorize_direct` (``points`` or ``ordering``: the nested-dissection
    ordering), or with ``"mg"`` the multigrid on the node grid of ``points``; solves to the relative residual
    ``rtol``, checked."""
    if resolve_method(method) != "mg":
        return factorize_direct(a, method, rtol, points, ordering)
    a = sp.csr_array(a)
    return Factorization(a, "mg", grid_solver(a, points, rtol), rtol)
