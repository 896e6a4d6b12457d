"""glibc's allocator tuned for the command line (issue 37 item 6: no per-evaluation cost beyond the arithmetic).

The reduced model's evaluations allocate and free arrays of a few MB (modes × output times × parameter sets) thousands
of times: a 400-step posterior of the shipped scene makes 12,833 evaluations.  glibc hands each such array back to the
kernel (above its mmap threshold, or by trimming the top of the heap) and the next one faults its pages in again:
2.16 million minor page faults and 5.4–5.8 s of system time against 14–15 s of user time, measured.  With the
thresholds below the freed memory is reused: 25,500 faults, 0.3 s of system time, peak memory 175 MB instead of
166 MB.  Arrays above :data:`MMAP_THRESHOLD` (the large builds' fields) are still mapped and returned at once.

Linux with glibc only (``mallopt``); elsewhere, or when the user set ``MALLOC_MMAP_THRESHOLD_`` or
``MALLOC_TRIM_THRESHOLD_`` themselves, nothing is changed.  Called by :func:`aromm.cli.main`, never on import.
"""

from __future__ import annotations

import ctypes
import os
import sys

M_TRIM_THRESHOLD = -1  # glibc's malloc.h
M_MMAP_THRESHOLD = -3
#: Allocations at least this large (bytes) are mapped and unmapped at once.
MMAP_THRESHOLD = 64 * 2**20
#: Free memory at the top of the heap kept for reuse up to this many bytes.
TRIM_THRESHOLD = 256 * 2**20


def tune_allocator() -> bool:
    """Set the thresholds (module docstring); True when glibc took them."""
    if not sys.platform.startswith("linux") or {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"} & set(os.environ):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
