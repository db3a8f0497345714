"""Bounded pools of worker processes shared by the students' private copies.

Each session of the presenter's kind has worker processes of its own: one for TangentBug
(:mod:`app.lanes`), one for a big scene's graphs (:mod:`app.big`, started on first use).
A classroom may hold dozens of private copies; processes of their own would grow without
bound (about 60 MB and a start-up of a second or so each, and a big scene's planning some
hundreds of MB more). The copies share two pools instead, one for each kind of work: at
most ``size`` processes each, started on first use, each answering one call at a time; a
call waits for a free worker. A worker's :class:`planners.Memo` then sees scenes of
several sessions in turn: that only costs reuse, never correctness (the planners are
pure and the memo is keyed on the values it caches).

Data flow::

    private session's slow lane (its scheduler thread)
      -> pool(scene, which)         # wait for a free worker (a queue of idle ones)
           worker(scene, which=...) # one ProcessLane: pickles out, result back
      -> the worker goes back to the queue
    private session's big scene (a BigJob's thread)
      -> with pool.lease() as worker: worker(scene, ...)   # interrupted if given up
"""

from __future__ import annotations

__all__ = ["WorkerPool"]

import contextlib
import queue
import threading
from collections.abc import Callable, Iterator
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
        with self.lease() as worker:
            return worker(scene, which=which)

    @contextlib.contextmanager
    def lease(self) -> Iterator[ProcessLane]:
        """Hold a free worker (waiting for one) for the caller alone until the block ends.

        The caller may :meth:`app.lanes.ProcessLane.interrupt` it while it holds it (a
        big scene's job given up, :mod:`app.big`): its process is replaced by a fresh
        one at once, and the worker goes back to the pool as usual.
        """
        worker = self._take()
        try:
            yield worker
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
