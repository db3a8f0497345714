"""planners.allocator: freed temporaries are reused, not faulted in again."""

from __future__ import annotations

import gc
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from planners.allocator import freeze_long_lived, keep_freed_memory

glibc = pytest.mark.skipif(
    platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
    reason="the thresholds are glibc's",
)

ROOT = Path(__file__).resolve().parents[2]

# An edit's pattern: many temporaries of a few hundred KiB alive together, then freed
# together, round after round. Prints the page faults of the rounds after the first.
_ROUNDS = textwrap.dedent(
    """
    import resource, sys
    import numpy as np
    if sys.argv[1] == "tuned":
        from planners.allocator import keep_freed_memory
        assert keep_freed_memory()
    def rounds(n):
        for _ in range(n):
            alive = [np.ones(50_000) for _ in range(60)]  # 60 x 390 KiB
            del alive
    rounds(2)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    rounds(20)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
    """
)


def _faults(mode: str) -> int:
    out = subprocess.run(
        [sys.executable, "-c", _ROUNDS, mode],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    return int(out.stdout.strip())


@glibc
def test_the_thresholds_are_set_under_glibc():
    assert keep_freed_memory() is True


@glibc
def test_an_edits_temporaries_are_reused_instead_of_faulted_in_again():
    default, tuned = _faults("default"), _faults("tuned")
    # Fresh pages every round: 20 x 60 x ~98 pages with glibc's defaults; reused, few.
    assert default > 20_000, default
    assert tuned < default / 20, (tuned, default)


def test_long_lived_objects_are_frozen_once_a_process():
    # The app's tests start it again and again in one process: a second freeze would
    # keep each stopped app's objects for good. What is made after the first stays in
    # the collector's sight.
    gc.unfreeze()
    try:
        assert freeze_long_lived() > 0
        made_after = [[k] for k in range(1000)]
        freeze_long_lived()
        tracked = {id(o) for o in gc.get_objects()}
        assert all(id(x) in tracked for x in made_after)
    finally:
        gc.unfreeze()
