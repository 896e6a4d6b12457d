"""Large temporaries reused from the heap instead of mapped and faulted in afresh (glibc malloc).

glibc serves an allocation above its mmap threshold (at most 32 MB) with a fresh ``mmap`` and returns it
to the kernel when freed, so every such temporary is faulted in, page by page and zero-filled, again.  Up to
128³ the node vectors of a voxel grid (17 MB) stay under the threshold; at 256³ they are 136 MB, and the
multigrid solve, the capacity products and the basis updates of a Krylov reduction create a few per
operation: a 256³ shifted solve took 158 CPU s for two columns, 72–84 s with the heap kept (measured
2026-12-02, 14 CG iterations each, same result).  :func:`kept_heap` switches ``mmap`` off and freed memory
stays in the process's heap for the next temporary of the same size; on leaving, the heap is trimmed and
glibc's limits are set to what its dynamic threshold reaches anyway (mmap above 32 MB, trim above 64 MB).
Elsewhere (no glibc: macOS, musl) it does nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
from collections.abc import Iterator
from functools import cache

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD, M_MMAP_MAX = -1, -3, -4  # mallopt parameters (malloc.h)
#: glibc's defaults for the number of mmapped chunks, and the largest dynamic mmap threshold (64-bit).
MMAP_MAX, MMAP_THRESHOLD = 65_536, 32 << 20


@cache
def _libc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
    except OSError:
        return None
    return libc if hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim") else None


@contextlib.contextmanager
def kept_heap() -> Iterator[bool]:
    """Within: freed large arrays are kept for reuse (module docstring).  Yields whether it took effect.

    >>> with kept_heap() as kept:
    ...     isinstance(kept, bool)
    True
    """
    libc = _libc()
    if libc is None:
        yield False
        return
    libc.mallopt(M_TRIM_THRESHOLD, ctypes.c_int(2**31 - 1))
    libc.mallopt(M_MMAP_MAX, ctypes.c_int(0))
    try:
        yield True
    finally:
        libc.mallopt(M_MMAP_MAX, ctypes.c_int(MMAP_MAX))
        libc.mallopt(M_MMAP_THRESHOLD, ctypes.c_int(MMAP_THRESHOLD))
        libc.mallopt(M_TRIM_THRESHOLD, ctypes.c_int(2 * MMAP_THRESHOLD))
        libc.malloc_trim(ctypes.c_size_t(0))
