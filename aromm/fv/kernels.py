"""The kernels of the matrix-free finite-volume solver (:mod:`aromm.fv.stencil`): residual, red–black Gauss–Seidel,
restriction and prolongation, each one pass over its data.

Two implementations of the same arithmetic: compiled loops (numba, ``pip install aromm[fast]``; threads over the
first axis, ``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads` sets how many) and numpy slices (no extra
dependency, ≈ 5–10× slower: each numpy operation is a pass of its own).  :func:`kernels` returns the numba set when
numba imports, else the numpy one; both are tested equal (tests/test_fv_multigrid.py).

Conventions: ``x``, ``b``, ``out`` are float64 arrays of the stencil's shape; the diagonal is summed from the links
in every kernel (never stored); a cell whose diagonal is zero carries no equation and is left unchanged.  A periodic
stencil's wrapped links join the last cell of every axis to the first (red–black sweeps need its axes even).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray
from aromm.fv.stencil import Stencil

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Kernels:
    """``product(st, x, out)``: out = A x; ``residual(st, b, x, out)``: out = b − A x; ``diagonal(st, out)``: the
    diagonal of A; ``sweep(st, b, x, colour)``: Gauss–Seidel on the cells with ``(i + j + k) % 2 == colour``;
    ``first_sweep(st, b, x, colour)``: that from x = 0 (x's values are not read: x ← 0, then the sweep);
    ``restrict(r, out)``: out = Pᵀ r; ``residual_restrict(st, b, x, out)``: out = Pᵀ (b − A x), no fine residual
    kept; ``prolong(e, x, alive, alpha)``: x += alpha P e on the live cells."""

    name: str
    product: Callable[[Stencil, FloatArray, FloatArray], None]
    diagonal: Callable[[Stencil, FloatArray], None]
    residual: Callable[[Stencil, FloatArray, FloatArray, FloatArray], None]
    sweep: Callable[[Stencil, FloatArray, FloatArray, int], None]
    first_sweep: Callable[[Stencil, FloatArray, FloatArray, int], None]
    restrict: Callable[[FloatArray, FloatArray], None]
    residual_restrict: Callable[[Stencil, FloatArray, FloatArray, FloatArray], None]
    prolong: Callable[[FloatArray, FloatArray, npt.NDArray[np.uint8], float], None]


Index = tuple[slice | int, ...]


def _links(st: Stencil, axis: int) -> list[tuple[npt.NDArray[np.float32], Index, Index]]:
    """(g, first cells, second cells) of the links along ``axis``: the open ones, and a periodic stencil's wrapped
    plane (last cell to first)."""
    g = st.links[axis]
    n = st.shape[axis]
    lo: list[slice | int] = [slice(None)] * 3
    hi: list[slice | int] = [slice(None)] * 3
    lo[axis], hi[axis] = slice(0, n - 1), slice(1, n)
    inner: Index = (slice(None),) * axis + (slice(0, n - 1),)
    out = [(g[inner] if st.periodic else g, tuple(lo), tuple(hi))]
    if st.periodic and n > 1:
        lo[axis], hi[axis] = n - 1, 0
        out.append((np.take(g, n - 1, axis=axis), tuple(lo), tuple(hi)))
    return out


def _add_fixed(st: Stencil, out: FloatArray, x: FloatArray | None = None) -> None:
    """out += f x on the two fixed planes (f alone without ``x``), no full-size temporary."""
    planes = np.moveaxis(out, st.axis, 0)  # a view: the fixed planes are its first and last
    values = None if x is None else np.moveaxis(x, st.axis, 0)
    planes[0] += st.low if values is None else st.low * values[0]
    planes[-1] += st.high if values is None else st.high * values[-1]


def _np_product(st: Stencil, x: FloatArray, out: FloatArray) -> None:
    out.fill(0.0)
    _add_fixed(st, out, x)
    for a in range(3):
        for g, lo, hi in _links(st, a):
            flow = g * (x[lo] - x[hi])
            out[lo] += flow
            out[hi] -= flow


def _np_residual(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    _np_product(st, x, out)
    np.subtract(b, out, out=out)


def _np_diagonal(st: Stencil, out: FloatArray) -> None:
    out.fill(0.0)
    _add_fixed(st, out)  # no full-size temporary (the floor runs it at 500³)
    for a in range(3):
        for g, lo, hi in _links(st, a):
            out[lo] += g
            out[hi] += g


def _np_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
    diagonal = np.empty(x.shape)
    _np_diagonal(st, diagonal)
    total = b.copy()
    for a in range(3):
        for g, lo, hi in _links(st, a):
            total[lo] += g * x[hi]
            total[hi] += g * x[lo]
    parity = sum(np.indices(x.shape, sparse=True)) % 2
    update = (parity == colour) & (diagonal > 0)
    x[update] = total[update] / diagonal[update]


def _np_first_sweep(st: Stencil, b: FloatArray, x: FloatArray, colour: int) -> None:
    x.fill(0.0)
    _np_sweep(st, b, x, colour)


def _np_restrict(r: FloatArray, out: FloatArray) -> None:
    for ax in range(3):
        r = np.add.reduceat(r, np.arange(0, r.shape[ax], 2), axis=ax)
    out[...] = r


def _np_residual_restrict(st: Stencil, b: FloatArray, x: FloatArray, out: FloatArray) -> None:
    r = np.empty(x.shape)
    _np_residual(st, b, x, r)
    _np_restrict(r, out)


def _np_prolong(e: FloatArray, x: FloatArray, alive: npt.NDArray[np.uint8], alpha: float) -> None:
    fine = np.repeat(np.repeat(np.repeat(e, 2, axis=0), 2, axis=1), 2, axis=2)
    x += alpha * alive * fine[: x.shape[0], : x.shape[1], : x.shape[2]]


NUMPY = Kernels("numpy", _np_product, _np_diagonal, _np_residual, _np_sweep, _np_first_sweep, _np_restrict,
                _np_residual_restrict, _np_prolong)


def kernels(name: str = "auto") -> Kernels:
    """``numba`` (compiled), ``numpy``, or ``auto``: numba when it imports."""
    if name == "numpy":
        return NUMPY
    try:
        from aromm.fv.compiled import COMPILED  # imports numba (≈ 0.3 s): only when a solve needs it
    except ImportError:
        if name == "numba":
            raise
        _say_numpy()
        return NUMPY
    return COMPILED


@cache
def _say_numpy() -> None:
    log.info("finite volumes: numba is not installed, the multigrid's kernels run in numpy (3–14× slower, "
             "benchmarks/kernels.py); pip install 'aromm[fast]' compiles them")
