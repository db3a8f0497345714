"""Keep freed memory for the next edit: glibc's allocator thresholds.

Planning one edit makes many numpy temporaries of a few hundred KiB (the candidate pairs
of the visibility test: 13,000 pairs of points are 420 KiB). glibc's ``malloc`` serves a
block above its *mmap threshold* (128 KiB at start, raised only by freeing such a block)
with fresh pages from the kernel and gives them back on ``free``, and it trims the
heap's free top beyond its *trim threshold*: either way the next edit's temporaries land
on fresh pages, and each 4 KiB page costs a page fault when first written. In a
32-obstacle student room that was about 790 faults a vertex drag, some 2 ms of a 16 ms
plan on the 2-core machine of ``docs/benchmarks.md``; with the thresholds below,
2 or 3.

:func:`keep_freed_memory` raises both thresholds for the calling process: blocks up to
:data:`MMAP_THRESHOLD` come from the heap and are reused, and each of glibc's heaps (one
per few threads) keeps up to :data:`TRIM_THRESHOLD` of freed memory at its top instead
of returning it. The peak a computation needs is unchanged (the big scenes of
``bench_big.py`` are measured with it). The app's entry point (``start_app``), its
worker processes and the command line call it at start; the planners themselves never
do (a library does not tune its caller's process).

Python's cycle collector is the other source of stalls. A full collection walks every
tracked object: in the app's process, after viser, shapely, numba and LLVM are loaded,
about 160,000 of them, 73 ms once in every few hundred edits of a 32-obstacle drag (and
50 ms in TangentBug's worker, once in about 60 plans). :func:`freeze_long_lived`, called
by the app once the compiled loops are loaded and by each worker after its first answer,
moves the objects alive then (modules, classes, functions: they live as long as the
process) out of the collector's sight (``gc.freeze``), once a process; a full collection then walks only
what was made since, a few milliseconds' worth. Objects frozen are still freed when
their last reference goes; only a cycle among them would stay, which the ``gc.collect``
just before the freeze leaves none of.
"""

from __future__ import annotations

__all__ = [
    "MMAP_THRESHOLD",
    "TRIM_THRESHOLD",
    "freeze_long_lived",
    "give_back_freed_memory",
    "keep_freed_memory",
]

import ctypes
import ctypes.util
import gc
import sys

MMAP_THRESHOLD = 32 << 20
"""Blocks up to this many bytes come from the heap (glibc's ``M_MMAP_THRESHOLD``)."""
TRIM_THRESHOLD = 32 << 20
"""Freed memory the heap keeps before giving it back (glibc's ``M_TRIM_THRESHOLD``)."""

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds for this process (module docstring).

    Returns True when both were set, False where there is no glibc (macOS, Windows,
    musl): there the allocator is left as it is and everything works the same, with the
    page faults.
    """
    libc = _glibc()
    if libc is None:
        return False
    try:
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    mmap_set = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    trim_set = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    return bool(mmap_set) and bool(trim_set)


def give_back_freed_memory() -> bool:
    """Return the memory the process freed to the system now (glibc's ``malloc_trim``).

    The thresholds above keep freed memory for the next edit; when a whole class has
    left a classroom, what its sessions freed is given back. False where there is no
    glibc (nothing is done).

    Examples
    --------
    >>> give_back_freed_memory() in (True, False)
    True
    """
    libc = _glibc()
    if libc is None:
        return False
    try:
        trim = libc.malloc_trim
    except AttributeError:
        return False
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    trim(0)
    return True


def _glibc() -> ctypes.CDLL | None:
    """Return the C library on Linux (None elsewhere, or if it cannot be loaded)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


def freeze_long_lived() -> int:
    """Collect cycles once, then keep every object alive now out of later collections.

    Once a process: where objects are frozen already, nothing more is (a process that
    starts the app again and again, as the tests do, would otherwise freeze each
    stopped app's objects for good). Returns how many objects are frozen
    (``gc.get_freeze_count``). See the module docstring; a process calls this once its
    imports are done.

    Examples
    --------
    >>> import gc
    >>> freeze_long_lived() > 0
    True
    >>> gc.unfreeze()  # a test's process is not the app's: let it collect them again
    """
    if gc.get_freeze_count() == 0:
        gc.collect()
        gc.freeze()
    return gc.get_freeze_count()
