"""The compiled (numba) kernels of :mod:`aromm.fv.kernels`, at module level so that numba caches them on disk: the
first run compiles them (≈ 5 s), later processes load them.  Imported only when a solve uses them (numba's own
import costs ≈ 0.3 s).  The arithmetic, conventions and tests are those of :mod:`aromm.fv.kernels`.

Every kernel runs row by row (fixed i, j; k the contiguous axis) and indexes the 3-d arrays directly (with a view of
each neighbour row, whose references numba counts, a colour sweep took 5.0 ns a cell at 46³ instead of 2.5).
:func:`_row` picks, once per row, the indices of the neighbours along i and j and of their links; where the box
ends, a valid index and a weight 0 stand for the missing link, and where a row lies on a fixed face of axis i or j,
its term ``f`` is weighted in: those rows run the weighted loop, the others (nearly all) the plain one.  Both loops
are free of branches, and LLVM vectorises them; the first and last cell of a row take the k links and axis k's fixed
faces.  A colour sweep computes the Gauss–Seidel value of every cell of the row (unit stride, vectorised) into a row
buffer and copies back that colour's cells: a cell's value depends on the other colour only, which the sweep does
not change (on an even periodic axis too; an odd periodic one is never swept: aromm.fv.multigrid).
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
PRODUCT, RESIDUAL, SWEEP, FIRST = 0, 1, 2, 3  # what _row writes per cell, from s = Σ g x_neighbour, d = Σ g + f (W/K)


@INLINE
def _update(mode, s, d, x, b, out, i, j, k, row):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """out[row][k] ← (A x)_ijk = d x − s, (b − A x)_ijk, the Gauss–Seidel value (b + s) / d (x where d = 0), or
    with FIRST that value from x = 0, b / d (0 where d = 0; x is not read)."""
    oi, oj = row
    if mode == SWEEP:
        out[oi, oj, k] = (b[i, j, k] + s) / d if d > 0.0 else x[i, j, k]
    elif mode == FIRST:
        out[oi, oj, k] = b[i, j, k] / d if d > 0.0 else 0.0
    elif mode == RESIDUAL:
        out[oi, oj, k] = b[i, j, k] - (d * x[i, j, k] - s)
    else:
        out[oi, oj, k] = d * x[i, j, k] - s


@INLINE
def _plane(gx, gy, fl, fh, x, near, k, weighted):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """(s, d) of cell k of the row from its neighbours along i and j and the fixed faces of axes i and j."""
    i, j, ia, ib, la, lb, jc, jd, lc, ld, rf, w = near
    g1, g2 = np.float64(gx[la, j, k]), np.float64(gx[lb, j, k])
    g3, g4 = np.float64(gy[i, lc, k]), np.float64(gy[i, ld, k])
    f = 0.0
    if weighted:
        g1, g2, g3, g4 = g1 * w[0], g2 * w[1], g3 * w[2], g4 * w[3]
        f = w[4] * fl[rf, k] + w[5] * fh[rf, k]
    return g1 * x[ia, j, k] + g2 * x[ib, j, k] + g3 * x[i, jc, k] + g4 * x[i, jd, k], g1 + g2 + g3 + g4 + f


@INLINE
def _inner(gx, gy, gz, fl, fh, b, x, out, row, near, mode, weighted):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """``_update`` of the row's cells 1 … n − 2."""
    i, j = near[0], near[1]
    for k in range(1, x.shape[2] - 1):
        gm, gp = np.float64(gz[i, j, k - 1]), np.float64(gz[i, j, k])
        s, d = _plane(gx, gy, fl, fh, x, near, k, weighted)
        _update(mode, s + gm * x[i, j, k - 1] + gp * x[i, j, k + 1], d + gm + gp, x, b, out, i, j, k, row)


@INLINE
def _side(i, n, periodic):  # type: ignore[no-untyped-def]
    """(previous cell, next cell, link to the previous, link to the next, weights) of index i on an axis of n."""
    before, after = i > 0 or periodic, i < n - 1 or periodic
    prev = i - 1 if i > 0 else (n - 1 if periodic else i)
    nxt = i + 1 if i < n - 1 else (0 if periodic else i)
    return prev, nxt, prev if before else 0, i if after else 0, 1.0 if before else 0.0, 1.0 if after else 0.0


@INLINE
def _row(gx, gy, gz, low, high, fl, fh, axis, periodic, b, x, out, row, i, j, mode):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """``_update(mode)`` of every cell (i, j, ·) into ``out[row]`` (module docstring); ``fl``, ``fh``: the fixed
    planes of axis 0 or 1 (a zero plane for axis 2).  Periodic: the previous cell of 0 is n − 1, by the wrapped
    link n − 1."""
    nx, ny, nz = x.shape
    ia, ib, la, lb, wa, wb = _side(i, nx, periodic)
    jc, jd, lc, ld, wc, wd = _side(j, ny, periodic)
    fa = 1.0 if (axis == 0 and i == 0) or (axis == 1 and j == 0) else 0.0
    fb = 1.0 if (axis == 0 and i == nx - 1) or (axis == 1 and j == ny - 1) else 0.0
    near = (i, j, ia, ib, la, lb, jc, jd, lc, ld, j if axis == 0 else (i if axis == 1 else 0),
            (wa, wb, wc, wd, fa, fb))
    last = nz - 1
    s, d = _plane(gx, gy, fl, fh, x, near, 0, True)  # the first cell
    if last > 0:
        s, d = s + np.float64(gz[i, j, 0]) * x[i, j, 1], d + np.float64(gz[i, j, 0])
    if periodic and last > 0:
        s, d = s + np.float64(gz[i, j, last]) * x[i, j, last], d + np.float64(gz[i, j, last])
    if axis == 2:
        d += low[i, j] + (high[i, j] if last == 0 else 0.0)
    _update(mode, s, d, x, b, out, i, j, 0, row)
    if wa * wb * wc * wd == 1.0 and fa + fb == 0.0:
        _inner(gx, gy, gz, fl, fh, b, x, out, row, near, mode, False)
    else:
        _inner(gx, gy, gz, fl, fh, b, x, out, row, near, mode, True)
    if last > 0:  # the last cell
        s, d = _plane(gx, gy, fl, fh, x, near, last, True)
        s, d = s + np.float64(gz[i, j, last - 1]) * x[i, j, last - 1], d + np.float64(gz[i, j, last - 1])
        if periodic:
            s, d = s + np.float64(gz[i, j, last]) * x[i, j, 0], d + np.float64(gz[i, j, last])
        if axis == 2:
            d += high[i, j]
        _update(mode, s, d, x, b, out, i, j, last, row)


@INLINE
def _links(gx, gy, low, high, axis, shape):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """(gx, gy, fl, fh) for :func:`_row`: an empty link array (an axis of one cell) replaced by a zero plane, so
    that index 0 is valid; the fixed planes of axis 0 or 1, or a zero plane."""
    nx, ny, nz = shape
    if gx.shape[0] == 0:
        gx = np.zeros((1, ny, nz), np.float32)
    if gy.shape[1] == 0:
        gy = np.zeros((nx, 1, nz), np.float32)
    fl, fh = (low, high) if axis != 2 else (np.zeros((1, nz)), np.zeros((1, nz)))
    return gx, gy, fl, fh


@numba.njit(cache=True, nogil=True)
def _rows(gx, gy, gz, low, high, axis, periodic, b, x, out, i, oi, mode, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """``_row(mode)`` of every row j of plane i into ``out[oi, j]``; SWEEP: into a row buffer, whose ``colour``
    cells are copied back; FIRST: those cells, and 0 in the others (x's old values are never used).  Compiled
    apart from the threaded kernels: inlined there, _row's index tuples failed numba's parallel array analysis."""
    _, ny, nz = x.shape
    i, oi = np.int64(i), np.int64(oi)  # a prange index may be unsigned: index arithmetic with it would be float
    gx, gy, fl, fh = _links(gx, gy, low, high, axis, x.shape)
    t = np.empty((1, 1, nz if mode >= SWEEP else 0))  # the row's Gauss–Seidel values, both colours
    for j in range(ny):
        if mode < SWEEP:
            _row(gx, gy, gz, low, high, fl, fh, axis, periodic, b, x, out, (oi, j), i, j, mode)
            continue
        _row(gx, gy, gz, low, high, fl, fh, axis, periodic, b, x, t, (0, 0), i, j, mode)
        if mode == FIRST:
            for k in range((i + j + colour + 1) % 2, nz, 2):
                x[i, j, k] = 0.0
        for k in range((i + j + colour) % 2, nz, 2):
            x[i, j, k] = t[0, 0, k]


@JIT
def residual(gx, gy, gz, low, high, axis, periodic, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    for i in prange(x.shape[0]):
        _rows(gx, gy, gz, low, high, axis, periodic, b, x, out, i, i, RESIDUAL, 0)


@JIT
def product(gx, gy, gz, low, high, axis, periodic, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    for i in prange(x.shape[0]):
        _rows(gx, gy, gz, low, high, axis, periodic, x, x, out, i, i, PRODUCT, 0)


@JIT
def sweep(gx, gy, gz, low, high, axis, periodic, b, x, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    for i in prange(x.shape[0]):
        _rows(gx, gy, gz, low, high, axis, periodic, b, x, x, i, i, SWEEP, colour)


@JIT
def first_sweep(gx, gy, gz, low, high, axis, periodic, b, x, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    for i in prange(x.shape[0]):
        _rows(gx, gy, gz, low, high, axis, periodic, b, x, x, i, i, FIRST, colour)


@JIT
def residual_restrict(gx, gy, gz, low, high, axis, periodic, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
    """out ← Pᵀ (b − A x): the residual of fine planes 2 ci and 2 ci + 1 into a two-plane buffer, summed by 2 × 2 × 2
    into coarse plane ci (no fine residual kept)."""
    nx, ny, nz = x.shape
    for ci in prange(out.shape[0]):
        t = np.zeros((2, ny + 1, nz + 1))  # one more along j and k: zeros past an odd axis' last cell
        for i in range(2 * ci, min(2 * ci + 2, nx)):
            _rows(gx, gy, gz, low, high, axis, periodic, b, x, t, i, i - 2 * ci, RESIDUAL, 0)
        for cj in range(out.shape[1]):
            for ck in range(out.shape[2]):
                out[ci, cj, ck] = (t[0, 2 * cj, 2 * ck] + t[0, 2 * cj, 2 * ck + 1] + t[0, 2 * cj + 1, 2 * ck]
                                   + t[0, 2 * cj + 1, 2 * ck + 1] + t[1, 2 * cj, 2 * ck] + t[1, 2 * cj, 2 * ck + 1]
                                   + t[1, 2 * cj + 1, 2 * ck] + t[1, 2 * cj + 1, 2 * ck + 1])


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

def nb_first_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
    first_sweep(*st.links, st.low, st.high, st.axis, st.periodic, b, x, colour)

def nb_residual_restrict(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    residual_restrict(*st.links, st.low, st.high, st.axis, st.periodic, b, x, out)


# the diagonal is needed by the rounding floor only (once a solve): numpy's serves
COMPILED = Kernels("numba", nb_product, NUMPY.diagonal, nb_residual, nb_sweep, nb_first_sweep, restrict,
                   nb_residual_restrict, prolong)
