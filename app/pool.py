"""A bounded pool of slow-lane worker processes shared by the students' private copies.

Each session of the presenter's kind has a worker process of its own for TangentBug
(:mod:`app.lanes`). A classroom may hold dozens of private copies; one process each would
grow without bound (about 60 MB and a start-up of a second or so each). The copies share
this pool instead: at most ``size`` processes, started on first use, each answering one
call at a time; a call waits for a free worker. A worker's :class:`planners.Memo` then
sees scenes of several sessions in turn: that only costs reuse, never correctness (the
planners are pure and the memo is keyed on the values it caches).

Data flow::

    private session's slow lane (its scheduler thread)
      -> pool(scene, which)         # wait for a free worker (a queue of idle ones)
           worker(scene, which=...) # one ProcessLane: pickles out, result back
      -> the worker goes back to the queue
"""

from __future__ import annotations

__all__ = ["WorkerPool"]

import queue
import threading
from collections.abc import Callable
from typing import Any

from app.lanes import ProcessLane


class WorkerPool:
    """At most ``size`` :class:`app.lanes.ProcessLane` workers computing ``fn``, shared.

    Parameters
    ----------
    fn
        A picklable function ``fn(scene, memo=..., which=...)`` (as for a
        :class:`ProcessLane`).
    size
        Most processes ever running at once (at least 1).
    """

    def __init__(self, fn: Callable[..., Any], size: int = 1) -> None:
        self._fn = fn
        self.size = max(1, int(size))
        """Most worker processes at once."""
        self._idle: queue.SimpleQueue[ProcessLane] = queue.SimpleQueue()
        self._all: list[ProcessLane] = []
        self._lock = threading.Lock()
        self._closed = False

    def __call__(self, scene: Any, which: tuple[str, ...]) -> Any:
        """Compute ``fn(scene, which=which)`` on a free worker (waiting for one)."""
        worker = self._take()
        try:
            return worker(scene, which=which)
        finally:
            self._idle.put(worker)

    def _take(self) -> ProcessLane:
        try:
            return self._idle.get_nowait()
        except queue.Empty:
            pass
        with self._lock:
            if self._closed:
                raise RuntimeError("the worker pool is closed")
            if len(self._all) < self.size:
                worker = ProcessLane(self._fn)
                self._all.append(worker)
                return worker
        return self._idle.get()

    @property
    def processes(self) -> int:
        """Worker processes started so far (never more than :attr:`size`)."""
        with self._lock:
            return len(self._all)

    def close(self) -> None:
        """Stop every worker (a call in progress ends with an error)."""
        with self._lock:
            self._closed = True
            workers, self._all = self._all, []
        for worker in workers:
            worker.close()
