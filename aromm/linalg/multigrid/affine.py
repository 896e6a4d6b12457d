"""Multigrid hierarchies of an affine family of voxel operators ``A(θ) = Σ_i θ_i A_i``, coarse levels built once.

The Galerkin coarse operator is linear in the fine one: ``Pᵀ A(θ) P = Σ_i θ_i Pᵀ A_i P`` with the trilinear P of
:func:`aromm.linalg.multigrid.assembled.prolongation` [Trottenberg2001, § 3.4].  So the coarse levels of every term
``A_i`` are computed once (one sparse triple product per term and level) and the hierarchy of any member of the
family — the shifted operators ``K(μ) + s C(μ)`` of the Krylov reduction, one per parameter point and shift — is
a weighted sum of stored sparse matrices on each level: a set-up costs O(nnz) instead of the triple products at
the fine level.  Memory: the coarse levels of every term, ≈ 1/7 of a fine term each.

The levels follow the rule of :class:`~aromm.linalg.multigrid.pcg.MultigridSolver` (coarsen while a level has
more than ``coarsest`` nodes and every axis at least 4 elements), so the solver takes them in place of its own
Galerkin products (:attr:`aromm.linalg.multigrid.assembled.GridMatrix.coarse`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.linalg.multigrid.assembled import GridMatrix, prolongation
from aromm.linalg.multigrid.pcg import COARSEST_NODES, coarsenable


@dataclass(frozen=True, eq=False)
class AffineGrid:
    """The terms ``A_i`` (on the unknowns, in their own order) of an affine voxel operator and their coarse levels."""

    terms: tuple[sp.csr_array, ...]
    layout: GridMatrix  # the grid of the unknowns (shape, node index), its matrix the first term
    levels: tuple[tuple[tuple[sp.csr_array, ...], tuple[int, int, int], npt.NDArray[np.bool_]], ...]

    @classmethod
    def build(cls, terms: Sequence[sp.csr_array], points: FloatArray | None,
              coarsest: int = COARSEST_NODES) -> AffineGrid:
        """Grid read off ``points`` (as ``GridMatrix.from_points``), every term's Galerkin levels."""
        if not terms:
            raise InputError("multigrid: an affine operator needs at least one term")
        mats = tuple(sp.csr_array(t) for t in terms)
        layout = GridMatrix.from_points(mats[0], points)
        shape, fixed = layout.shape, layout.missing()
        current = [GridMatrix(t, layout.shape, layout.index).full() for t in mats]
        for i, t in enumerate(current):  # full() put identity rows on absent nodes: the terms must not carry them
            current[i] = sp.csr_array(t - sp.diags_array(fixed.astype(float))) if fixed.any() else t
        levels: list[tuple[tuple[sp.csr_array, ...], tuple[int, int, int], npt.NDArray[np.bool_]]] = []
        while True:
            elements = (shape[0] - 1, shape[1] - 1, shape[2] - 1)
            if (levels and not coarsenable(elements, int(np.prod(shape)), coarsest)) or min(elements) < 4:
                break
            p, shape, fixed = prolongation(shape, fixed)
            current = [sp.csr_array(p.T @ t @ p) for t in current]
            levels.append((tuple(current), shape, fixed))
        return cls(mats, layout, tuple(levels))

    def operator(self, weights: Sequence[float]) -> GridMatrix:
        """``Σ_i w_i A_i`` on the unknowns with its coarse levels (identity rows on fixed nodes), for the solver."""
        if len(weights) != len(self.terms):
            raise InputError(f"multigrid: {len(weights)} weights for {len(self.terms)} affine terms")
        coarse = tuple((_combine(mats, weights) + sp.diags_array(fixed.astype(float)), shape, fixed)
                       for mats, shape, fixed in self.levels)
        return GridMatrix(_combine(self.terms, weights), self.layout.shape, self.layout.index, coarse=coarse)

    @property
    def nbytes(self) -> int:
        """Bytes of the stored coarse levels (the fine terms belong to the caller)."""
        return sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes for mats, _, _ in self.levels for m in mats)


def _combine(mats: Sequence[sp.csr_array], weights: Sequence[float]) -> sp.csr_array:
    total = float(weights[0]) * mats[0]
    for w, m in zip(weights[1:], mats[1:], strict=True):
        if w != 0.0:
            total = total + float(w) * m
    return sp.csr_array(total)
