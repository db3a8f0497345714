"""planners.allocator: freed blocks are reused, not faulted in again (issue 15)."""

from __future__ import annotations

import platform
import resource

import numpy as np
import pytest

from planners.allocator import MMAP_THRESHOLD, keep_freed_memory

glibc = pytest.mark.skipif(
    platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
    reason="the thresholds are glibc's",
)


@glibc
def test_the_thresholds_are_set_under_glibc():
    assert keep_freed_memory() is True


@glibc
def test_blocks_below_the_threshold_are_reused_without_page_faults():
    keep_freed_memory()
    words = MMAP_THRESHOLD // 8 // 2  # half the threshold: from the heap
    pages = words * 8 // 4096
    for _ in range(3):  # the heap grows to hold one block (faults once)
        np.ones(words).sum()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(20):  # each block written whole, then freed
        np.ones(words).sum()
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    # Fresh pages every time would be 20 * pages faults; reused, next to none.
    assert faults < pages, (faults, 20 * pages)
