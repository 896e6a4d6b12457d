"""A basis that grows by appended columns without copying itself each time.

The offline reductions append a few columns at a time to a basis of n-vectors (n up to 1.7e7 at 256³).
``np.column_stack([basis, x])`` copies the whole basis for every block: twice its memory at the peak and
O(r² n) bytes moved over a build (measured at 64³: 16.5 of 121 CPU s of a Krylov reduction).  Here the
columns live in a column-major (Fortran) buffer with spare room; a basis handed out is the view
``buffer[:, :r]`` (contiguous, BLAS-ready), and appending to the latest view writes after it.

The first buffer reserves address space for :func:`reservable_columns` columns (:func:`reservation_budget`): pages
never written are never resident, so the reservation costs nothing until columns are written (except under an
address-space limit, which it leaves room under), and a basis within it never moves.  Growing
past it (by :data:`GROWTH`, one copy) holds the old and the new buffer at once — at 256³ a 64-column basis is
8.7 GB, and such a copy is what ran a 256³ build out of 24 GB.

>>> import numpy as np
>>> columns = ColumnBuffer(rows=4)
>>> v = columns.append(None, np.ones((4, 1)))
>>> w = columns.append(v, np.zeros((4, 2)))
>>> w.shape, np.shares_memory(v, w)
((4, 3), True)
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from aromm.core.system import FloatArray

log = logging.getLogger(__name__)

#: Room made when the buffer is full: this factor times the columns needed.
GROWTH = 1.5
#: Columns of a new buffer at least: the Krylov spans of the wood VERs hold 59–63 columns (24³–128³).
FIRST = 64
#: Columns reserved at most (the Krylov greedy stops at 4 × the order, 200 columns at its default order 50).
MOST_RESERVED = 256
#: Share of the physical memory a reservation may span: Linux's default (heuristic) overcommit refuses one mapping
#: larger than the memory and swap, and a reservation that large would leave no room for the rest anyway.
RESERVED_SHARE = 0.75
#: Share of the address space left under a limit (``ulimit -v``, RLIMIT_AS) that a reservation may take: under such
#: a limit reserved addresses count in full, written or not.
LIMITED_SHARE = 0.5


def physical_memory() -> int | None:
    """Bytes of physical memory, or None where the platform does not tell (``os.sysconf``)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return None


def address_headroom() -> int | None:
    """Bytes of address space left under the process's RLIMIT_AS soft limit, or None without a limit (or where the
    platform does not tell: ``resource``, ``/proc/self/statm``)."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/statm") as statm:
            used = int(statm.read().split()[0]) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ImportError, OSError, ValueError, AttributeError):
        return None
    return max(int(soft) - used, 0)


def reservation_budget(physical: int | None, headroom: int | None) -> int | None:
    """Bytes a first buffer may reserve: :data:`RESERVED_SHARE` of the physical memory and :data:`LIMITED_SHARE` of
    the address space left under a limit, whichever is smaller (None when neither is known).

    >>> reservation_budget(24 * 10**9, None), reservation_budget(24 * 10**9, 8 * 10**9)
    (18000000000, 4000000000)
    """
    budgets = [int(RESERVED_SHARE * physical) if physical is not None else None,
               int(LIMITED_SHARE * headroom) if headroom is not None else None]
    known = [b for b in budgets if b is not None]
    return min(known) if known else None


def reservable_columns(rows: int, budget: int | None) -> int:
    """Columns of float64 ``rows``-vectors that ``budget`` bytes hold, within [:data:`FIRST`,
    :data:`MOST_RESERVED`] (:data:`FIRST` when the budget is unknown).

    >>> reservable_columns(257**3, 18 * 10**9)  # 256³ elements, 3/4 of 24 GB: 132 columns of 136 MB
    132
    >>> reservable_columns(25**3, 18 * 10**9)
    256
    """
    if budget is None:
        return FIRST
    return int(min(MOST_RESERVED, max(FIRST, budget // (8 * max(rows, 1)))))


class ColumnBuffer:
    """The column-major storage of one growing basis of ``rows`` rows (module docstring)."""

    def __init__(self, rows: int, reserve: int | None = None) -> None:
        self.rows = rows
        if reserve is None:
            reserve = reservable_columns(rows, reservation_budget(physical_memory(), address_headroom()))
        self.reserve = reserve
        self._buffer: FloatArray | None = None
        self._width = 0  # columns of the latest view handed out
        self.version = 0  # counts the times the leading columns were written over (combine_in_place)

    def is_latest(self, basis: FloatArray | None) -> bool:
        """Whether ``basis`` is the latest view of the buffer's leading columns (so columns can be written after
        it; an older, narrower view is not: its next columns belong to a later basis)."""
        buf = self._buffer
        if buf is None or basis is None:
            return False
        same_start = basis.ctypes.data == buf.ctypes.data and basis.strides == buf[:, :1].strides
        return same_start and basis.shape[1] == self._width and basis.base is buf

    def append(self, basis: FloatArray | None, x: FloatArray) -> FloatArray:
        """``[basis, x]`` as a view of the buffer: written in place after ``basis`` when it is the latest view
        and there is room, else copied once into a buffer :data:`GROWTH` times larger."""
        r = 0 if basis is None else basis.shape[1]
        need = r + x.shape[1]
        buf = self._buffer
        if buf is None or not self.is_latest(basis) or buf.shape[1] < need:
            grown = self._allocate(need, first=buf is None)
            if basis is not None:
                # while it is copied the old basis is alive too: at 256³ a 64-column basis is 8.7 GB
                log.info("basis buffer: %d columns copied into a new buffer of %d (%.2f GB held during the copy)",
                         r, grown.shape[1], (buf.nbytes if buf is not None else 0) / 1e9 + 8e-9 * self.rows * need)
                grown[:, :r] = basis
            self._buffer = buf = grown
        buf[:, r:need] = x
        self._width = need
        return buf[:, :need]

    def _allocate(self, need: int, first: bool) -> FloatArray:
        """A new buffer for ``need`` columns: the reservation the first time (fewer columns if the system refuses
        that much address space), else :data:`GROWTH` × ``need``."""
        width = max(int(GROWTH * need), need, FIRST)
        if first and self.reserve > width:
            try:
                return np.empty((self.rows, self.reserve), order="F")
            except MemoryError:
                log.info("basis buffer: %d columns of address space refused; reserving %d", self.reserve, width)
        return np.empty((self.rows, width), order="F")

    def combine_in_place(self, basis: FloatArray, coefficients: FloatArray, chunk: int = 65_536) -> FloatArray:
        """``basis @ coefficients`` written over the buffer's leading columns, by row chunks (no second n × r
        array); ``basis`` (the latest view) is garbage afterwards.  Needs no more columns than ``basis`` has."""
        if not self.is_latest(basis) or coefficients.shape[1] > basis.shape[1]:
            return np.asarray(basis @ coefficients)
        assert self._buffer is not None
        out = self._buffer[:, :coefficients.shape[1]]
        for start in range(0, self.rows, chunk):
            rows = slice(start, min(start + chunk, self.rows))
            out[rows] = basis[rows] @ coefficients  # the right side is a new array: then written over the rows
        self._width = out.shape[1]
        self.version += 1
        return out


class GrowingProjection:
    """``VᵀA_tV`` of symmetric square terms A_t for the latest basis V of a :class:`ColumnBuffer`, grown as columns
    come in: for V = [V₀, X], ``[[V₀ᵀAV₀, V₀ᵀAX], [XᵀAV₀, XᵀAX]]`` needs the products ``A X`` only.  ``apply(A, X)``
    and ``dot(X, Y) = XᵀY`` are the engine's (a distributed engine sums ``dot`` over its ranks).

    >>> import numpy as np
    >>> a = np.diag([1.0, 2.0, 3.0])
    >>> columns = ColumnBuffer(rows=3)
    >>> grown = GrowingProjection([a], lambda op, x: op @ x, lambda x, y: x.T @ y)
    >>> v = columns.append(None, np.eye(3)[:, :1])
    >>> _ = grown.memo(columns, v)
    >>> grown.memo(columns, columns.append(v, np.eye(3)[:, 1:]))[id(a)].diagonal().tolist()
    [1.0, 2.0, 3.0]
    """

    def __init__(self, operators: Sequence[Any], apply: Callable[[Any, FloatArray], FloatArray],
                 dot: Callable[[FloatArray, FloatArray], FloatArray]) -> None:
        self.operators, self.apply, self.dot = list(operators), apply, dot
        self._state = (-1, 0)  # (version of the buffer, width) of the last projected basis
        self._blocks: dict[int, FloatArray] = {}

    def memo(self, columns: ColumnBuffer, basis: FloatArray) -> dict[int, FloatArray]:
        """The memo of :func:`aromm.reduction.rom.project` (id of an operator → its projection) for ``basis``."""
        version, width = self._state
        extends = columns.is_latest(basis) and version == columns.version and basis.shape[1] >= width
        start = width if extends else 0
        new = basis[:, start:]
        blocks = {}
        for a in self.operators:
            ax = self.apply(a, new)
            top = self.dot(basis[:, :start], ax)
            corner = self.dot(new, ax)
            old = self._blocks[id(a)] if start else np.zeros((0, 0))
            blocks[id(a)] = np.block([[old, top], [top.T, (corner + corner.T) / 2]])
        self._blocks, self._state = blocks, (columns.version, basis.shape[1])
        return dict(blocks)
