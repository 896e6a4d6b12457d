"""A 27-point operator on a node grid stored as its 27 coefficient arrays: the V-cycle's coarse levels.

Row ``i`` at node (k, j, l) of a (nz, ny, nx) grid couples to the node at (k + dz, j + dy, l + dx), dz, dy, dx ∈
{−1, 0, 1}, with the coefficient ``data[o, k, j, l]``, o = 9 (dz + 1) + 3 (dy + 1) + (dx + 1) (o = 13 the
diagonal); a periodic grid wraps the neighbours around, a box grid has zero coefficients where they are missing.
This is how the Galerkin coarse operator of the voxel Q1 grid comes out of its element classes
(:meth:`aromm.linalg.multigrid.hierarchy.ElementLevel.stencil`), so no column index is stored: 27 values a node
(4 bytes each in the V-cycle's float32) against 27 values and 27 int32 indices of the same rows in CSR, and the
product streams the coefficients once (a coarse level is 1/8 of the grid above it: in CSR the first two levels'
column indices held 30 B/voxel of the fine grid, scipy having made them int64).

The product is compiled when numba is installed (:mod:`aromm.linalg.multigrid.coarse_stencil_compiled`, one pass);
otherwise 27 shifted multiply-adds on a padded copy of x, equal up to the order of the sums
(tests/test_coarse_stencil.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray

OFFSETS = tuple(np.ndindex(3, 3, 3))  # (dz + 1, dy + 1, dx + 1) in the order of o
DIAGONAL = 13

Product = Callable[[FloatArray, FloatArray, FloatArray, bool], None]


@dataclass(frozen=True, eq=False)
class StencilMatrix:
    """``data`` (27, nz, ny, nx): the coefficients of each row (see the module docstring); ``periodic`` wraps;
    ``fixed`` (flat node indices) are held at zero: their rows and columns are the identity's, applied in the
    product, so a constrained level shares the free level's coefficients (:meth:`with_fixed`).

    >>> data = np.zeros((27, 2, 3, 4))
    >>> data[DIAGONAL] = 2.0
    >>> data[DIAGONAL + 1] = -1.0  # the x neighbour
    >>> m = StencilMatrix(data, periodic=True)
    >>> (m @ np.arange(24.0))[:4].tolist()  # 2 x_l − x_{l+1}, x_4 wrapping to x_0
    [-1.0, 0.0, 1.0, 6.0]
    >>> (m.with_fixed(np.arange(24) == 1) @ np.arange(24.0))[:4].tolist()  # node 1 held: x_1 read as 0, row 1 = x_1
    [0.0, 1.0, 1.0, 6.0]
    """

    data: FloatArray
    periodic: bool
    fixed: npt.NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    _work: dict[str, FloatArray] = field(default_factory=dict, repr=False)  # x with the fixed nodes zeroed

    def __post_init__(self) -> None:
        if self.data.ndim != 4 or self.data.shape[0] != 27 or not self.data.flags.c_contiguous:
            raise InputError(f"stencil matrix: data must be a contiguous (27, nz, ny, nx) array, got "
                             f"{self.data.shape}")

    @property
    def node_shape(self) -> tuple[int, int, int]:
        _, nz, ny, nx = self.data.shape
        return (nz, ny, nx)

    @property
    def shape(self) -> tuple[int, int]:
        n = int(np.prod(self.node_shape))
        return (n, n)

    @property
    def dtype(self) -> np.dtype:
        return self.data.dtype

    def diagonal(self) -> FloatArray:
        out = np.array(self.data[DIAGONAL].reshape(-1))
        out[self.fixed] = 1.0
        return out

    def with_data(self, data: FloatArray) -> StencilMatrix:
        """The same grid and fixed nodes with other coefficients (e.g. a weighted sum of terms' coefficients)."""
        return StencilMatrix(np.ascontiguousarray(data).reshape(self.data.shape), self.periodic, self.fixed)

    def with_fixed(self, mask: npt.NDArray[np.bool_]) -> StencilMatrix:
        """The nodes in ``mask`` (flat) held at zero besides those already held; the coefficients are shared."""
        fixed = np.union1d(self.fixed, np.flatnonzero(mask)).astype(np.intp)
        return StencilMatrix(self.data, self.periodic, fixed)

    def matvec(self, v: FloatArray, out: FloatArray | None = None) -> FloatArray:
        """``out`` ← A v for a flat node vector (in the coefficients' precision)."""
        x = np.ascontiguousarray(v, dtype=self.dtype).reshape(self.node_shape)
        y = np.empty(self.node_shape, dtype=self.dtype) if out is None else out.reshape(self.node_shape)
        if y.dtype != self.dtype or not y.flags.c_contiguous or np.may_share_memory(x, y):
            raise InputError(f"stencil matrix: out must be a separate contiguous {self.dtype} vector, got {y.dtype}")
        if self.fixed.size:  # the held nodes' columns read as zero
            held = self._work.get("x")
            if held is None or held.shape != x.shape or held.dtype != x.dtype:
                held = self._work["x"] = np.empty_like(x)
            np.copyto(held, x)
            held.reshape(-1)[self.fixed] = 0.0
            x = held
        kernel = compiled_product()
        if kernel is not None:
            kernel(self.data, x, y, self.periodic)
        else:
            numpy_product(self.data, x, y, self.periodic)
        if self.fixed.size:  # and their rows are the identity's
            y.reshape(-1)[self.fixed] = np.ravel(v)[self.fixed]
        return y.reshape(-1) if out is None else out

    def __matmul__(self, v: FloatArray) -> FloatArray:
        return self.matvec(v)

    def abs_row_sums(self) -> FloatArray:
        """Σ_j abs(a_ij) per row, one coefficient array at a time (no copy of the whole); a held row's is 1."""
        out = np.zeros(self.node_shape)
        held = np.zeros(self.shape[0], dtype=bool)
        held[self.fixed] = True
        held = held.reshape(self.node_shape)
        for o, (iz, iy, ix) in enumerate(OFFSETS):
            term = np.abs(self.data[o])
            if self.fixed.size:  # no column of a held node
                term[_at_neighbour(held, (iz, iy, ix))] = 0.0
            out += term
        out[held] = 1.0
        return out.reshape(-1)

    def tocsr(self) -> sp.csr_array:
        """The same operator in CSR (float64): for tests and inspection."""
        n = self.shape[0]
        index = np.arange(n).reshape(self.node_shape)
        rows, cols, values = [], [], []
        for o, (iz, iy, ix) in enumerate(OFFSETS):
            neighbour = _at_neighbour(index, (iz, iy, ix))
            keep = self.data[o] != 0
            rows.append(index[keep])
            cols.append(neighbour[keep])
            values.append(self.data[o][keep].astype(float))
        out = sp.csr_array((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
        if not self.fixed.size:
            return out
        keep = np.ones(n)
        keep[self.fixed] = 0.0
        free = sp.diags_array(keep)
        return sp.csr_array(free @ out @ free + sp.diags_array(1.0 - keep))

    def toarray(self) -> FloatArray:
        return self.tocsr().toarray()


def _at_neighbour(values: npt.NDArray[np.generic], offset: tuple[int, ...]) -> npt.NDArray[np.generic]:
    """``values`` at each node's neighbour of stencil offset ``offset`` (an entry of :data:`OFFSETS`), wrapped around
    the grid (on a box the wrapped entries meet zero coefficients)."""
    return np.roll(values, tuple(1 - i for i in offset), axis=(0, 1, 2))


def numpy_product(data: FloatArray, x: FloatArray, y: FloatArray, periodic: bool) -> None:
    """y ← A x by 27 shifted multiply-adds on x padded by one node (wrapped, or zeros on a box)."""
    padded = np.pad(x, 1, mode="wrap" if periodic else "constant")
    term = np.empty_like(y)
    nz, ny, nx = y.shape
    y.fill(0.0)
    for o, (iz, iy, ix) in enumerate(OFFSETS):
        np.multiply(data[o], padded[iz:iz + nz, iy:iy + ny, ix:ix + nx], out=term)
        y += term


@cache
def compiled_product() -> Product | None:
    """The compiled product ``product(data, x, out, periodic)`` (numba), or None without numba."""
    try:
        from aromm.linalg.multigrid.coarse_stencil_compiled import product  # imports numba: only when used
    except ImportError:
        return None
    return product  # type: ignore[no-any-return]
