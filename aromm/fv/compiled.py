"""The compiled (numba) kernels of :mod:`aromm.fv.kernels`, at module level so that numba caches them on disk: the
first run compiles them (≈ 5 s), later processes load them.  Imported only when a solve uses them (numba's own
import costs ≈ 0.3 s).  The arithmetic, conventions and tests are those of :mod:`aromm.fv.kernels`.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from aromm.core.system import FloatArray
from aromm.fv.kernels import NUMPY, Kernels
from aromm.fv.stencil import Stencil

JIT = numba.njit(parallel=True, cache=True, nogil=True)


@numba.njit(inline="always", cache=True)
def gather(gx, gy, gz, low, high, axis, periodic, x, i, j, k):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """(Σ g x_neighbour, Σ g + f) of cell (i, j, k); ``periodic``: the wrapped links too (link n − 1 of an axis joins
    its last cell to its first)."""
    nx, ny, nz = x.shape
    s = 0.0
    d = 0.0
    if i > 0 or periodic:
        g = np.float64(gx[i - 1, j, k])  # i − 1 = −1 reads the wrapped link n − 1 (periodic only)
        s += g * x[i - 1, j, k]
        d += g
    if i < nx - 1 or periodic:
        g = np.float64(gx[i, j, k])
        s += g * x[(i + 1) % nx, j, k]
        d += g
    if j > 0 or periodic:
        g = np.float64(gy[i, j - 1, k])
        s += g * x[i, j - 1, k]
        d += g
    if j < ny - 1 or periodic:
        g = np.float64(gy[i, j, k])
        s += g * x[i, (j + 1) % ny, k]
        d += g
    if k > 0 or periodic:
        g = np.float64(gz[i, j, k - 1])
        s += g * x[i, j, k - 1]
        d += g
    if k < nz - 1 or periodic:
        g = np.float64(gz[i, j, k])
        s += g * x[i, j, (k + 1) % nz]
        d += g
    if axis == 0:
        d += (low[j, k] if i == 0 else 0.0) + (high[j, k] if i == nx - 1 else 0.0)
    elif axis == 1:
        d += (low[i, k] if j == 0 else 0.0) + (high[i, k] if j == ny - 1 else 0.0)
    else:
        d += (low[i, j] if k == 0 else 0.0) + (high[i, j] if k == nz - 1 else 0.0)
    return s, d

@JIT
def residual(gx, gy, gz, low, high, axis, periodic, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, ny, nz = x.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                s, d = gather(gx, gy, gz, low, high, axis, periodic, x, i, j, k)
                out[i, j, k] = b[i, j, k] - (d * x[i, j, k] - s)

@JIT
def product(gx, gy, gz, low, high, axis, periodic, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, ny, nz = x.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                s, d = gather(gx, gy, gz, low, high, axis, periodic, x, i, j, k)
                out[i, j, k] = d * x[i, j, k] - s

@JIT
def sweep(gx, gy, gz, low, high, axis, periodic, b, x, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, ny, nz = x.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range((i + j + colour) % 2, nz, 2):
                s, d = gather(gx, gy, gz, low, high, axis, periodic, x, i, j, k)
                if d > 0.0:
                    x[i, j, k] = (b[i, j, k] + s) / d

@JIT
def restrict(r, out):  # type: ignore[no-untyped-def]
    nx, ny, nz = r.shape
    cx, cy, cz = out.shape
    for ci in prange(cx):
        for cj in range(cy):
            for ck in range(cz):
                t = 0.0
                for i in range(2 * ci, min(2 * ci + 2, nx)):
                    for j in range(2 * cj, min(2 * cj + 2, ny)):
                        for k in range(2 * ck, min(2 * ck + 2, nz)):
                            t += r[i, j, k]
                out[ci, cj, ck] = t

@JIT
def prolong(e, x, alive, alpha):  # type: ignore[no-untyped-def]
    nx, ny, nz = x.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                if alive[i, j, k]:
                    x[i, j, k] += alpha * e[i // 2, j // 2, k // 2]

def nb_residual(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    residual(*st.links, st.low, st.high, st.axis, st.periodic, b, x, out)

def nb_product(st: Stencil, x: FloatArray, out: FloatArray) -> None:
    product(*st.links, st.low, st.high, st.axis, st.periodic, x, out)

def nb_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
    sweep(*st.links, st.low, st.high, st.axis, st.periodic, b, x, colour)


# the diagonal is needed by the rounding floor only (once a solve): numpy's serves
COMPILED = Kernels("numba", nb_product, NUMPY.diagonal, nb_residual, nb_sweep, restrict, prolong)
