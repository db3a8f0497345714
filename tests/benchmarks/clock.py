"""A stopwatch shared by run.py and peers.py (they run in different interpreters).

Standard library only: peers.py runs in the peers' environment, where the project is
not installed. Both scripts find this module next to them (sys.path[0]).
"""

from __future__ import annotations

import gc
import time


class Clock:
    """Wall-clock and CPU time (of this process) since creation, in ms."""

    def __init__(self) -> None:
        gc.collect()  # the same for every tool: no garbage left over from the last run
        self.wall = time.perf_counter()
        self.cpu = time.process_time()

    def stop(self) -> tuple[float, float]:
        """Return (wall ms, CPU ms) since creation."""
        return (time.perf_counter() - self.wall) * 1e3, (
            time.process_time() - self.cpu
        ) * 1e3
