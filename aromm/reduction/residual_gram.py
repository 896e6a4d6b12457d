"""Residual norms of reduced frequency responses from one Gram matrix per basis (offline/online split).

For inputs ``b(μ) = U a(μ)`` and an affine operator ``K(μ) + s C(μ) = Σ_t θ_t(μ, s) A_t`` (θ_t = c_t(μ) for a
conductance term, s c_t(μ) for a capacity term), the residual of a reduced solution x on the basis V is

    b − (K + sC) V x = M c,   M = [U, A_1 V, …, A_m V],   c = [a; −θ_1 x; …; −θ_m x],

so ``‖b − (K + sC) V x‖² = cᵀ (MᵀM) c`` [Haasdonk2008, § 4]: MᵀM is formed once per basis (m sparse × block products
and one Gram product, by row chunks so that only a chunk of M is ever held), after which every training point
and shift costs O((p + m r)²) instead of two sparse products with the whole basis.  The squared norm is a
difference of terms of the size of ‖b‖², so relative residuals below ≈ 1e-7 are at round-off (clamped at 0):
ample for choosing the worst training point.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from aromm.core.system import FloatArray
from aromm.reduction.residual_form import residual_norms

#: Rows of M held at a time while forming MᵀM ...
CHUNK = 32_768
#: ... at least this many node planes of a voxel grid: a row block is computed from the slab of elements touching
#: its planes, one more layer than its own, so half a plane (CHUNK at 256³) did 4× the work of whole planes.
PLANES = 4


@dataclass(frozen=True)
class ResidualGram:
    """MᵀM of the module docstring for one basis (``key`` identifies it), with p inputs, m terms, r columns."""

    key: Hashable
    gram: FloatArray
    inputs: int
    terms: int
    order: int

    @classmethod
    def of(cls, key: Hashable, u: FloatArray, operators: Sequence[sp.csr_array], basis: FloatArray,
           chunk: int | None = None) -> ResidualGram:
        """``chunk`` rows at a time (default: :data:`CHUNK`, at least :data:`PLANES` node planes of a voxel grid)."""
        p, m, r = u.shape[1], len(operators), basis.shape[1]
        if chunk is None:
            chunk = max(CHUNK, *(PLANES * int(getattr(a, "plane_nodes", 0)) for a in operators))
        gram = np.zeros((p + m * r, p + m * r))
        rows_m = np.empty((min(chunk, basis.shape[0]), p + m * r))  # one chunk of M, filled in place chunk by chunk
        slab = max((int(a.slab_size(rows_m.shape[0])) for a in operators if hasattr(a, "slab_size")), default=0)
        work = np.empty(slab * r)  # a matrix-free operator's slab product, reused (row_block)
        for start in range(0, basis.shape[0], chunk):
            rows = slice(start, min(start + chunk, basis.shape[0]))
            block = rows_m[:rows.stop - rows.start]
            block[:, :p] = u[rows]
            for i, a in enumerate(operators):
                block[:, p + i * r:p + (i + 1) * r] = _rows_product(a, rows, basis, work)
            gram += block.T @ block  # one symmetric rank-k update (BLAS syrk): half the flops of block by block
        return cls(key, gram, p, m, r)

    def norms(self, a: FloatArray, *, k: FloatArray, c: FloatArray, shifts: FloatArray, x: FloatArray) -> FloatArray:
        """``‖b_i − (K(μ) + s C(μ)) V x_ki‖`` (S × q) for input coefficients ``a`` (p × q), the conductance and capacity
        terms' coefficients ``k``, ``c`` at μ, the ``shifts`` s and reduced solutions ``x`` (S × r × q)
        (:func:`aromm.reduction.residual_form.residual_norms`)."""
        return residual_norms(self.gram, a, k=k, c=c, shifts=shifts, solutions=x)


def _rows_product(a: sp.csr_array, rows: slice, basis: FloatArray, work: FloatArray) -> FloatArray:
    """Rows ``rows`` of ``a @ basis``; a matrix-free operator computes them from its own slab (``row_block``,
    into ``work``)."""
    if hasattr(a, "row_block"):
        return np.asarray(a.row_block(rows.start, rows.stop, basis, work))
    return np.asarray(a[rows] @ basis)
