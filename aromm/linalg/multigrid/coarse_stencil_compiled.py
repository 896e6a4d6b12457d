"""The compiled product of :class:`aromm.linalg.multigrid.coarse_stencil.StencilMatrix`, at module level so that
numba caches it on disk.  Imported only when a product uses it.

Per output row (fixed z and y) the nine neighbour rows of x are added into a row buffer, each with its three x
shifts in one contiguous loop over the interior of the row (``y_i += l_i x_{i−1} + c_i x_i + r_i x_{i+1}``), the two
end nodes apart (wrapped, or their missing neighbour skipped on a box); the row is stored once.  benchmarks/kernels.py
gives its ns per coarse node against scipy's CSR product of the same rows (which reads twice the bytes).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _neighbour(index, shift, n, periodic):  # type: ignore[no-untyped-def]
    """index + shift on an axis of n nodes: wrapped when periodic, −1 when missing (box)."""
    other = index + shift
    if 0 <= other < n:
        return other
    return other % n if periodic else -1


@numba.njit(cache=True, nogil=True, fastmath=False)
def product(data, x, out, periodic):  # type: ignore[no-untyped-def]
    nz, ny, nx = x.shape
    coefficients, rows, result = data.reshape(27, nz * ny, nx), x.reshape(nz * ny, nx), out.reshape(nz * ny, nx)
    y = np.empty(nx, dtype=out.dtype)  # the output row, accumulated here and stored once
    for k in range(nz):
        for j in range(ny):
            r = k * ny + j
            y[:] = 0
            for iz in range(3):
                kk = _neighbour(k, iz - 1, nz, periodic)
                for iy in range(3):
                    jj = _neighbour(j, iy - 1, ny, periodic)
                    if kk < 0 or jj < 0:
                        continue
                    row = rows[kk * ny + jj]
                    o = 9 * iz + 3 * iy
                    left, centre, right = coefficients[o, r], coefficients[o + 1, r], coefficients[o + 2, r]
                    for i in range(1, nx - 1):
                        y[i] += left[i] * row[i - 1] + centre[i] * row[i] + right[i] * row[i + 1]
                    for i in (0, nx - 1):  # the end nodes (one node when nx = 1: added once)
                        total = centre[i] * row[i]
                        before, after = _neighbour(i, -1, nx, periodic), _neighbour(i, 1, nx, periodic)
                        if before >= 0:
                            total += left[i] * row[before]
                        if after >= 0:
                            total += right[i] * row[after]
                        y[i] += total
                        if nx == 1:
                            break
            result[r] = y
