"""Geometric multigrid for an assembled SPD matrix whose unknowns are nodes of a voxel grid.

This is ``aromm.linalg.direct.factorize(a, method="mg", points=...)``: any system the voxel assembler builds
(steady K + H, a time step C/dt + K, a shifted Steklov operator), with fixed-temperature nodes eliminated.
The grid is read off the unknowns' coordinates; eliminated nodes become identity rows of the full grid.
Coarse operators are Galerkin products Pᵀ A P with the trilinear prolongation of
:mod:`aromm.linalg.multigrid.hierarchy` (masked on eliminated nodes), assembled by scipy; smoothing, V-cycle and
CG are those of :class:`~aromm.linalg.multigrid.pcg.MultigridSolver`.  Memory is that of the assembled matrix
(≈ 330 B per unknown) plus ≈ 1/7 for the coarse levels: the matrix-free path of the homogenisation
(:mod:`aromm.homogenization.cell_problems`) is the lean one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.linalg.multigrid.hierarchy import prolongation_1d


@dataclass(frozen=True, eq=False)
class GridMatrix:
    """``matrix`` on the grid nodes ``index`` (flat, x fastest) of a (nz, ny, nx) node grid; others absent."""

    matrix: sp.csr_array
    shape: tuple[int, int, int]
    index: npt.NDArray[np.intp]
    periodic: bool = False
    #: Galerkin levels below the fine one, (matrix, node shape, fixed mask) each, when computed beforehand
    #: (:mod:`aromm.linalg.multigrid.affine`); empty: :func:`galerkin` products at set-up.
    coarse: tuple[tuple[sp.csr_array, tuple[int, int, int], npt.NDArray[np.bool_]], ...] = ()

    @classmethod
    def from_points(cls, a: sp.csr_array, points: FloatArray | None) -> GridMatrix:
        if points is None:
            raise InputError("linear solver 'mg' needs the unknowns' coordinates (a voxel system); use 'amg' here")
        pts = np.asarray(points, dtype=float)
        extent = max(float(np.ptp(pts)), 1e-300)
        axes = []
        for col in (2, 1, 0):  # z, y, x
            values, inverse = np.unique(np.round(pts[:, col] / extent, 9), return_inverse=True)
            axes.append((len(values), inverse))
        shape = (axes[0][0], axes[1][0], axes[2][0])
        index = np.ravel_multi_index((axes[0][1], axes[1][1], axes[2][1]), shape)
        if len(np.unique(index)) != len(index) or min(shape) < 2:
            raise InputError("linear solver 'mg': the unknowns do not lie on a voxel node grid; use 'amg'")
        return cls(sp.csr_array(a), shape, index.astype(np.intp))

    @property
    def n(self) -> int:
        return int(np.prod(self.shape))

    @property
    def elements(self) -> tuple[int, int, int]:
        nz, ny, nx = self.shape
        return (nz - 1, ny - 1, nx - 1)

    def missing(self) -> npt.NDArray[np.bool_]:
        mask = np.ones(self.n, dtype=bool)
        mask[self.index] = False
        return mask

    def full(self) -> sp.csr_array:
        """The matrix on every grid node: identity rows and columns for the absent ones."""
        if len(self.index) == self.n and np.array_equal(self.index, np.arange(self.n)):
            return self.matrix  # already in grid order, nothing absent
        embed = sp.csr_array((np.ones(len(self.index)), (self.index, np.arange(len(self.index)))),
                             shape=(self.n, len(self.index)))
        return sp.csr_array(embed @ self.matrix @ embed.T + sp.diags_array(self.missing().astype(float)))


def prolongation(shape: tuple[int, int, int], fixed: npt.NDArray[np.bool_]
                 ) -> tuple[sp.csr_array, tuple[int, int, int], npt.NDArray[np.bool_]]:
    """P (trilinear, fixed fine and coarse nodes masked) to the grid ``shape`` from the next coarser one, the
    coarser grid's shape and fixed mask."""
    mats = [prolongation_1d(n - 1, periodic=False) for n in shape]
    coarse_shape = (mats[0].shape[1], mats[1].shape[1], mats[2].shape[1])
    positions = [np.minimum(2 * np.arange(m.shape[1]), n - 1) for m, n in zip(mats, shape, strict=True)]
    coarse_fixed = fixed.reshape(shape)[np.ix_(*positions)].ravel()
    p = sp.kron(sp.kron(mats[0], mats[1]), mats[2], format="csr")
    p = sp.csr_array(sp.diags_array((~fixed).astype(float)) @ p @ sp.diags_array((~coarse_fixed).astype(float)))
    return p, coarse_shape, coarse_fixed


def galerkin(a: sp.csr_array, shape: tuple[int, int, int], fixed: npt.NDArray[np.bool_]
             ) -> tuple[sp.csr_array, tuple[int, int, int], npt.NDArray[np.bool_]]:
    """Pᵀ A P on the next coarser grid, P trilinear with fixed (identity) nodes masked; fixed coarse nodes too."""
    p, coarse_shape, coarse_fixed = prolongation(shape, fixed)
    coarse = sp.csr_array(p.T @ a @ p + sp.diags_array(coarse_fixed.astype(float)))
    return coarse, coarse_shape, coarse_fixed
