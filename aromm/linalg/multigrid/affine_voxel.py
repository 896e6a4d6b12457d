"""Coarse levels of an affine family of matrix-free voxel operators, built once per term.

The Galerkin coarse operator is linear in the fine one, ``Pᵀ (Σ_i θ_i A_i) P = Σ_i θ_i Pᵀ A_i P`` [Trottenberg2001,
§ 3.4], and every coarse level of a voxel grid has the same 27-point pattern whatever the coefficients
(:meth:`aromm.linalg.multigrid.hierarchy.ElementLevel.stencil`).  So the levels of each term ``A_i`` (free of
fixed faces) are built once, and those of any member ``K(μ) + s C(μ)`` — one per parameter point and shift of the
Krylov reduction — are a weighted sum of their value arrays, level by level (the coarsest, in CSR, sharing one
index structure).  The fixed faces are then applied as for the fixed-temperature problems of homogenisation
(:meth:`~aromm.linalg.multigrid.hierarchy.CoarseLevel.with_fixed`).  A set-up then reads the stored values once
instead of coarsening the fine grid and assembling 27-point rows (≈ 19 CPU s a shift at 256³, mostly fresh arrays).
Memory: one value array per term and level (a 256³ grid: 232 MB per term at the first coarse level in float32).  The
coarse levels but the coarsest are float32 (the V-cycle's precision): each term's values are rounded once, their sum
once more.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.linalg.multigrid.coarse_stencil import StencilMatrix
from aromm.linalg.multigrid.hierarchy import CoarseLevel, galerkin_levels
from aromm.linalg.multigrid.operator import VoxelOperator


@dataclass(frozen=True, eq=False)
class AffineLevels:
    """The free coarse levels of the first term and the value arrays of every term's, level by level."""

    pattern: tuple[CoarseLevel, ...]
    values: tuple[tuple[FloatArray, ...], ...]  # values[level][term]

    @classmethod
    def build(cls, terms: Sequence[VoxelOperator], coarsest: int, dtype: type = np.float32) -> AffineLevels:
        """Every term's Galerkin levels (fixed faces dropped), checked to share one pattern."""
        if not terms:
            raise InputError("multigrid: an affine voxel operator needs at least one term")
        per_term = [galerkin_levels(replace(t, fixed=(), keep_weights=False), coarsest, dtype) for t in terms]
        pattern = per_term[0]
        for levels in per_term[1:]:
            if len(levels) != len(pattern) or any(not _same_pattern(a.matrix, b.matrix)
                                                  for a, b in zip(levels, pattern, strict=True)):
                raise InputError("multigrid: the terms of an affine voxel operator must share one grid")
        values = tuple(tuple(levels[k].matrix.data for levels in per_term) for k in range(len(pattern)))
        return cls(tuple(pattern), values)

    def levels(self, weights: Sequence[float], fixed: tuple[str, ...]) -> list[CoarseLevel]:
        """The coarse levels of ``Σ_i w_i A_i`` with the ``fixed`` faces held at zero (identity rows)."""
        if len(weights) != len(self.values[0]):
            raise InputError(f"multigrid: {len(weights)} weights for {len(self.values[0])} affine voxel terms")
        out = []
        for level, values in zip(self.pattern, self.values, strict=True):
            data = np.zeros_like(values[0])
            scaled = np.empty_like(values[0])
            for w, v in zip(weights, values, strict=True):
                if w != 0.0:
                    np.multiply(v, w, out=scaled)
                    data += scaled
            m = level.matrix
            combined = (m.with_data(data) if isinstance(m, StencilMatrix)
                        else sp.csr_array((data, m.indices, m.indptr), shape=m.shape))
            out.append(replace(level, matrix=combined).with_fixed(fixed))
        return out

    @property
    def nbytes(self) -> int:
        """Bytes held: every term's values and the shared index arrays (the coarsest level's CSR)."""
        return sum(v.nbytes for level in self.values for v in level) + sum(
            level.matrix.indices.nbytes + level.matrix.indptr.nbytes for level in self.pattern
            if not isinstance(level.matrix, StencilMatrix))


def _same_pattern(a: sp.csr_array | StencilMatrix, b: sp.csr_array | StencilMatrix) -> bool:
    """Whether two levels' value arrays line up entry by entry (same grid; same CSR columns)."""
    if isinstance(a, StencilMatrix) or isinstance(b, StencilMatrix):
        return isinstance(a, StencilMatrix) and isinstance(b, StencilMatrix) and a.data.shape == b.data.shape
    return a.shape == b.shape and np.array_equal(a.indices, b.indices)
