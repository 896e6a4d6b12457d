"""aromm.cli.allocator: freed arrays of a few MB are reused instead of faulted in again (issue 37 item 6).

Truth: the kernel's count of minor page faults (getrusage) of a fresh interpreter that allocates, fills and frees three
6 MB arrays 100 times, as the reduced model's evaluations do; with glibc's default thresholds the rounds fault about
40 % of their 439,000 pages in again (180,821 faults measured), with the command line's thresholds almost none
(885).  One array freed and allocated again is reused even by the defaults (glibc raises its mmap threshold on the
first free); several freed together are trimmed from the top of the heap.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = """
import resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from aromm.cli.allocator import tune_allocator
    assert tune_allocator()
np.ones(750_000)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(100):
    a, b, c = np.ones(750_000), np.ones(750_000), np.ones(750_000)  # 6 MB each, freed together
    del a, b, c
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_the_tuned_allocator_reuses_freed_arrays() -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    faults = {mode: int(subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True,
                                       env=env, check=True).stdout) for mode in ("default", "tuned")}
    pages = 100 * 3 * 6_000_000 // 4096
    assert faults["default"] >= pages // 4, faults  # glibc returns and re-faults them
    assert faults["tuned"] <= pages // 100, faults
