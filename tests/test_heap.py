"""The kept heap: a freed large array is reused without faulting its pages in again (glibc), and leaving the
context gives the heap back."""

from __future__ import annotations

import resource

import numpy as np
import pytest

from aromm.core.heap import _libc, kept_heap

SIZE = 64 << 20  # bytes: above glibc's largest mmap threshold (32 MB)


def faults_of_a_second_array() -> int:
    """Minor page faults of filling a fresh SIZE-byte array after one of the same size was freed."""
    first = np.ones(SIZE // 8)
    del first
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    second = np.ones(SIZE // 8)
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    del second
    return faults


@pytest.mark.skipif(_libc() is None, reason="no glibc malloc (mallopt) on this platform")
def test_a_freed_large_array_is_reused_within_and_mapped_afresh_outside() -> None:
    outside = faults_of_a_second_array()
    with kept_heap() as kept:
        assert kept
        within = faults_of_a_second_array()
    after = faults_of_a_second_array()
    assert outside >= 16 and after >= 16  # ≥ 64 MB in pages of 4 KB to 2 MB, mapped afresh
    assert within <= outside / 8
