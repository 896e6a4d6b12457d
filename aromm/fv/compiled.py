"""The compiled (numba) kernels of :mod:`aromm.fv.kernels`, at module level so that numba caches them on disk: the
first run compiles them (≈ 5 s), later processes load them.  Imported only when a solve uses them (numba's own
import costs ≈ 0.3 s).  The arithmetic, conventions and tests are those of :mod:`aromm.fv.kernels`.

Every kernel runs row by row (fixed i, j; k the contiguous axis): :func:`_row` picks, once per row, the four
neighbour rows along i and j and their links (a zero row where the box ends), so that its loop over the inner cells
has no branch and LLVM vectorises it; the first and last cell of the row take the k links and the fixed faces of
axis k.  A colour sweep computes the Gauss–Seidel value of every cell of the row (unit stride, vectorised) into a
row buffer and copies back that colour's cells: a cell's value depends on the other colour only, which the sweep
does not change (on an even periodic axis too; an odd periodic one is never swept: aromm.fv.multigrid).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from aromm.core.system import FloatArray
from aromm.fv.kernels import NUMPY, Kernels
from aromm.fv.stencil import Stencil

JIT = numba.njit(parallel=True, cache=True, nogil=True)
INLINE = numba.njit(inline="always", cache=True)
PRODUCT, RESIDUAL, SWEEP = 0, 1, 2  # what _row writes per cell, from s = Σ g x_neighbour and d = Σ g + f (W/K)


@INLINE
def _update(mode, s, d, k, xr, br, outr):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """outr[k] ← (A x)_k = d x_k − s, (b − A x)_k, or the Gauss–Seidel value (b_k + s) / d (x_k where d = 0)."""
    if mode == SWEEP:
        outr[k] = (br[k] + s) / d if d > 0.0 else xr[k]
    elif mode == RESIDUAL:
        outr[k] = br[k] - (d * xr[k] - s)
    else:
        outr[k] = d * xr[k] - s


@INLINE
def _plane(rows, k):  # type: ignore[no-untyped-def]
    """(s, d) of cell k from the in-plane neighbours' rows (links along i and j, both sides) and fixed rows."""
    ga, xa, gb, xb, gc, xc, gd, xd, fa, fb = rows
    g1, g2, g3, g4 = np.float64(ga[k]), np.float64(gb[k]), np.float64(gc[k]), np.float64(gd[k])
    return g1 * xa[k] + g2 * xb[k] + g3 * xc[k] + g4 * xd[k], g1 + g2 + g3 + g4 + fa[k] + fb[k]


@INLINE
def _row(gx, gy, gz, low, high, axis, periodic, b, x, outr, i, j, mode, zg, zf):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """``_update(mode)`` of every cell (i, j, ·) into the row ``outr``.  The neighbour rows along i and j and their
    links are picked once (``zg``, ``zf``: zero rows of links and fixed terms where the box ends), so the loop over
    the inner cells has no branch and vectorises; the row's two end cells add the k links and axis k's fixed faces.
    Periodic: index −1 reads the wrapped link n − 1 (last cell to first)."""
    nx, ny, nz = x.shape
    xi = x[i]
    xa, ga = (x[i - 1, j], gx[i - 1, j]) if i > 0 or periodic else (xi[j], zg)
    xb, gb = (x[(i + 1) % nx, j], gx[i, j]) if i < nx - 1 or periodic else (xi[j], zg)
    xc, gc = (xi[j - 1], gy[i, j - 1]) if j > 0 or periodic else (xi[j], zg)
    xd, gd = (xi[(j + 1) % ny], gy[i, j]) if j < ny - 1 or periodic else (xi[j], zg)
    fa = low[j] if axis == 0 and i == 0 else (low[i] if axis == 1 and j == 0 else zf)
    fb = high[j] if axis == 0 and i == nx - 1 else (high[i] if axis == 1 and j == ny - 1 else zf)
    rows = (ga, xa, gb, xb, gc, xc, gd, xd, fa, fb)
    xr, br, gr = xi[j], b[i, j], gz[i, j]
    last = nz - 1
    s, d = _plane(rows, 0)  # the first cell
    if last > 0:
        s, d = s + np.float64(gr[0]) * xr[1], d + np.float64(gr[0])
    if periodic and last > 0:
        s, d = s + np.float64(gr[last]) * xr[last], d + np.float64(gr[last])
    if axis == 2:
        d += low[i, j] + (high[i, j] if last == 0 else 0.0)
    _update(mode, s, d, 0, xr, br, outr)
    for k in range(1, last):
        gm, gp = np.float64(gr[k - 1]), np.float64(gr[k])
        s, d = _plane(rows, k)
        _update(mode, s + gm * xr[k - 1] + gp * xr[k + 1], d + gm + gp, k, xr, br, outr)
    if last > 0:  # the last cell
        s, d = _plane(rows, last)
        s, d = s + np.float64(gr[last - 1]) * xr[last - 1], d + np.float64(gr[last - 1])
        if periodic:
            s, d = s + np.float64(gr[last]) * xr[0], d + np.float64(gr[last])
        if axis == 2:
            d += high[i, j]
        _update(mode, s, d, last, xr, br, outr)


@JIT
def residual(gx, gy, gz, low, high, axis, periodic, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, ny, nz = x.shape
    zg, zf = np.zeros(nz, np.float32), np.zeros(nz)
    for i in prange(nx):
        for j in range(ny):
            _row(gx, gy, gz, low, high, axis, periodic, b, x, out[i, j], i, j, RESIDUAL, zg, zf)


@JIT
def product(gx, gy, gz, low, high, axis, periodic, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, ny, nz = x.shape
    zg, zf = np.zeros(nz, np.float32), np.zeros(nz)
    for i in prange(nx):
        for j in range(ny):
            _row(gx, gy, gz, low, high, axis, periodic, x, x, out[i, j], i, j, PRODUCT, zg, zf)


@INLINE
def _sweep_plane(gx, gy, gz, low, high, axis, periodic, b, x, i, colour, t, zg, zf):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """Gauss–Seidel on the cells of plane i with ``(i + j + k) % 2 == colour``; ``t``: a row buffer."""
    for j in range(x.shape[1]):
        _row(gx, gy, gz, low, high, axis, periodic, b, x, t, i, j, SWEEP, zg, zf)
        x[i, j, (i + j + colour) % 2::2] = t[(i + j + colour) % 2::2]


@JIT
def sweep(gx, gy, gz, low, high, axis, periodic, b, x, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    nx, _, nz = x.shape
    zg, zf = np.zeros(nz, np.float32), np.zeros(nz)
    for i in prange(nx):
        _sweep_plane(gx, gy, gz, low, high, axis, periodic, b, x, i, colour, np.empty(nz), zg, zf)


@JIT
def residual_restrict(gx, gy, gz, low, high, axis, periodic, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """out ← Pᵀ (b − A x): each fine row's residual, summed by pairs into its coarse row (no fine residual kept)."""
    nx, ny, nz = x.shape
    zg, zf = np.zeros(nz, np.float32), np.zeros(nz)
    for ci in prange(out.shape[0]):
        t = np.empty(nz)
        out[ci] = 0.0
        for i in range(2 * ci, min(2 * ci + 2, nx)):
            for j in range(ny):
                _row(gx, gy, gz, low, high, axis, periodic, b, x, t, i, j, RESIDUAL, zg, zf)
                o = out[ci, j // 2]
                o[: nz // 2] += t[0 : nz - 1 : 2] + t[1:nz:2]
                if nz % 2:
                    o[nz // 2] += t[nz - 1]


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

def nb_residual_restrict(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    residual_restrict(*st.links, st.low, st.high, st.axis, st.periodic, b, x, out)


# the diagonal is needed by the rounding floor only (once a solve): numpy's serves
COMPILED = Kernels("numba", nb_product, NUMPY.diagonal, nb_residual, nb_sweep, restrict, nb_residual_restrict,
                   prolong)
