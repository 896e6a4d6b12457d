"""The compiled product of :class:`aromm.linalg.multigrid.coarse_stencil.StencilMatrix`, at module level so that
numba caches it on disk.  Imported only when a product uses it.

Per output row (fixed z and y) the nine neighbour rows of x are added, each with its three x shifts in one
contiguous loop over the interior of the row (``y_i += l_i x_{i−1} + c_i x_i + r_i x_{i+1}``), the two end nodes
apart (wrapped, or their missing neighbour skipped on a box).  At 200³ fine voxels (10⁶ coarse nodes, float32, one
thread) it took 14–17 ms against 13–15 ms for scipy's CSR product of the same rows, which reads twice the bytes.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def _neighbour(index, shift, n, periodic):  # type: ignore[no-untyped-def]
    """index + shift on an axis of n nodes: wrapped when periodic, −1 when missing (box)."""
    other = index + shift
    if 0 <= other < n:
        return other
    return other % n if periodic else -1


@numba.njit(cache=True, nogil=True, inline="always")
def _end(y, coefficients, row, i, periodic):  # type: ignore[no-untyped-def]
    """y_i += the three x-neighbour terms of end node i (0 or nx − 1); ``coefficients`` (left, centre, right)."""
    left, centre, right = coefficients
    nx = row.shape[0]
    total = centre[i] * row[i]
    before, after = _neighbour(i, -1, nx, periodic), _neighbour(i, 1, nx, periodic)
    if before >= 0:
        total += left[i] * row[before]
    if after >= 0:
        total += right[i] * row[after]
    y[i] += total


@numba.njit(cache=True, nogil=True, fastmath=False)
def product(data, x, out, periodic):  # type: ignore[no-untyped-def]
    nz, ny, nx = x.shape
    for k in range(nz):
        for j in range(ny):
            y = out[k, j]
            y[:] = 0
            for iz in range(3):
                kk = _neighbour(k, iz - 1, nz, periodic)
                for iy in range(3):
                    jj = _neighbour(j, iy - 1, ny, periodic)
                    if kk < 0 or jj < 0:
                        continue
                    row = x[kk, jj]
                    o = 9 * iz + 3 * iy
                    left, centre, right = data[o, k, j], data[o + 1, k, j], data[o + 2, k, j]
                    for i in range(1, nx - 1):
                        y[i] += left[i] * row[i - 1] + centre[i] * row[i] + right[i] * row[i + 1]
                    _end(y, (left, centre, right), row, 0, periodic)
                    if nx > 1:
                        _end(y, (left, centre, right), row, nx - 1, periodic)
