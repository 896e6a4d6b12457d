"""The kernels of the matrix-free finite-volume solver (:mod:`aromm.fv.stencil`): residual, red–black Gauss–Seidel,
restriction and prolongation, each one pass over its data.

Two implementations of the same arithmetic: compiled loops (numba, ``pip install aromm[fast]``; threads over the
first axis, ``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads` sets how many) and numpy slices (no extra
dependency, ≈ 5–10× slower: each numpy operation is a pass of its own).  :func:`kernels` returns the numba set when
numba imports, else the numpy one; both are tested equal (tests/test_fv_multigrid.py).

Conventions: ``x``, ``b``, ``out`` are float64 arrays of the stencil's shape; the diagonal is summed from the links
in every kernel (never stored); a cell whose diagonal is zero carries no equation and is left unchanged.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray
from aromm.fv.stencil import Stencil


@dataclass(frozen=True)
class Kernels:
    """``product(st, x, out)``: out = A x; ``residual(st, b, x, out)``: out = b − A x; ``diagonal(st, out)``: the
    diagonal of A; ``sweep(st, b, x, colour)``: Gauss–Seidel on the cells with
    ``(i + j + k) % 2 == colour``; ``restrict(r, out)``: out = Pᵀ r; ``prolong(e, x, alive, alpha)``:
    x += alpha P e on the live cells."""

    name: str
    product: Callable[[Stencil, FloatArray, FloatArray], None]
    diagonal: Callable[[Stencil, FloatArray], None]
    residual: Callable[[Stencil, FloatArray, FloatArray, FloatArray], None]
    sweep: Callable[[Stencil, FloatArray, FloatArray, int], None]
    restrict: Callable[[FloatArray, FloatArray], None]
    prolong: Callable[[FloatArray, FloatArray, npt.NDArray[np.uint8], float], None]


def _lo_hi(axis: int, n: int) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    lo = [slice(None)] * 3
    hi = [slice(None)] * 3
    lo[axis], hi[axis] = slice(0, n - 1), slice(1, n)
    return tuple(lo), tuple(hi)


def _np_product(st: Stencil, x: FloatArray, out: FloatArray) -> None:
    np.multiply(st.fixed(), x, out=out)
    for a, g in enumerate(st.links):
        lo, hi = _lo_hi(a, x.shape[a])
        flow = g * (x[lo] - x[hi])
        out[lo] += flow
        out[hi] -= flow


def _np_residual(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    _np_product(st, x, out)
    np.subtract(b, out, out=out)


def _np_diagonal(st: Stencil, out: FloatArray) -> None:
    out.fill(0.0)
    planes = np.moveaxis(out, st.axis, 0)  # a view; no full-size temporary (the floor runs it at 500³)
    planes[0] += st.low
    planes[-1] += st.high
    for a, g in enumerate(st.links):
        lo, hi = _lo_hi(a, out.shape[a])
        out[lo] += g
        out[hi] += g


def _np_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
    diagonal = np.empty(x.shape)
    _np_diagonal(st, diagonal)
    total = b.copy()
    for a, g in enumerate(st.links):
        lo, hi = _lo_hi(a, x.shape[a])
        total[lo] += g * x[hi]
        total[hi] += g * x[lo]
    parity = sum(np.indices(x.shape, sparse=True)) % 2
    update = (parity == colour) & (diagonal > 0)
    x[update] = total[update] / diagonal[update]


def _np_restrict(r: FloatArray, out: FloatArray) -> None:
    for ax in range(3):
        r = np.add.reduceat(r, np.arange(0, r.shape[ax], 2), axis=ax)
    out[...] = r


def _np_prolong(e: FloatArray, x: FloatArray, alive: npt.NDArray[np.uint8], alpha: float) -> None:
    fine = np.repeat(np.repeat(np.repeat(e, 2, axis=0), 2, axis=1), 2, axis=2)
    x += alpha * alive * fine[: x.shape[0], : x.shape[1], : x.shape[2]]


NUMPY = Kernels("numpy", _np_product, _np_diagonal, _np_residual, _np_sweep, _np_restrict, _np_prolong)


@cache
def _compiled() -> Kernels:
    """The numba kernels, compiled on first use (cached on disk by numba)."""
    import numba
    from numba import prange

    jit = numba.njit(parallel=True, cache=True, nogil=True)

    @numba.njit(inline="always")
    def gather(gx, gy, gz, low, high, axis, x, i, j, k):  # type: ignore[no-untyped-def]  # noqa: PLR0917
        """(Σ g x_neighbour, Σ g + f) of cell (i, j, k)."""
        nx, ny, nz = x.shape
        s = 0.0
        d = 0.0
        if i > 0:
            g = np.float64(gx[i - 1, j, k])
            s += g * x[i - 1, j, k]
            d += g
        if i < nx - 1:
            g = np.float64(gx[i, j, k])
            s += g * x[i + 1, j, k]
            d += g
        if j > 0:
            g = np.float64(gy[i, j - 1, k])
            s += g * x[i, j - 1, k]
            d += g
        if j < ny - 1:
            g = np.float64(gy[i, j, k])
            s += g * x[i, j + 1, k]
            d += g
        if k > 0:
            g = np.float64(gz[i, j, k - 1])
            s += g * x[i, j, k - 1]
            d += g
        if k < nz - 1:
            g = np.float64(gz[i, j, k])
            s += g * x[i, j, k + 1]
            d += g
        if axis == 0:
            d += (low[j, k] if i == 0 else 0.0) + (high[j, k] if i == nx - 1 else 0.0)
        elif axis == 1:
            d += (low[i, k] if j == 0 else 0.0) + (high[i, k] if j == ny - 1 else 0.0)
        else:
            d += (low[i, j] if k == 0 else 0.0) + (high[i, j] if k == nz - 1 else 0.0)
        return s, d

    @jit
    def residual(gx, gy, gz, low, high, axis, b, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
        nx, ny, nz = x.shape
        for i in prange(nx):
            for j in range(ny):
                for k in range(nz):
                    s, d = gather(gx, gy, gz, low, high, axis, x, i, j, k)
                    out[i, j, k] = b[i, j, k] - (d * x[i, j, k] - s)

    @jit
    def product(gx, gy, gz, low, high, axis, x, out):  # type: ignore[no-untyped-def]  # noqa: PLR0917
        nx, ny, nz = x.shape
        for i in prange(nx):
            for j in range(ny):
                for k in range(nz):
                    s, d = gather(gx, gy, gz, low, high, axis, x, i, j, k)
                    out[i, j, k] = d * x[i, j, k] - s

    @jit
    def sweep(gx, gy, gz, low, high, axis, b, x, colour):  # type: ignore[no-untyped-def]  # noqa: PLR0917
        nx, ny, nz = x.shape
        for i in prange(nx):
            for j in range(ny):
                for k in range((i + j + colour) % 2, nz, 2):
                    s, d = gather(gx, gy, gz, low, high, axis, x, i, j, k)
                    if d > 0.0:
                        x[i, j, k] = (b[i, j, k] + s) / d

    @jit
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

    @jit
    def prolong(e, x, alive, alpha):  # type: ignore[no-untyped-def]
        nx, ny, nz = x.shape
        for i in prange(nx):
            for j in range(ny):
                for k in range(nz):
                    if alive[i, j, k]:
                        x[i, j, k] += alpha * e[i // 2, j // 2, k // 2]

    def nb_residual(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
        residual(*st.links, st.low, st.high, st.axis, b, x, out)

    def nb_product(st: Stencil, x: FloatArray, out: FloatArray) -> None:
        product(*st.links, st.low, st.high, st.axis, x, out)

    def nb_diagonal(st: Stencil, out: FloatArray) -> None:
        _np_diagonal(st, out)  # setup and the final floor only: not worth a compiled twin

    def nb_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
        sweep(*st.links, st.low, st.high, st.axis, b, x, colour)

    return Kernels("numba", nb_product, nb_diagonal, nb_residual, nb_sweep, restrict, prolong)


def kernels(name: str = "auto") -> Kernels:
    """``numba`` (compiled), ``numpy``, or ``auto``: numba when it imports."""
    if name == "numpy":
        return NUMPY
    try:
        return _compiled()
    except ImportError:
        if name == "numba":
            raise
        return NUMPY
