"""Whose callbacks run when: the presenter first, every other browser in its turn.

viser runs the app's GUI and scene callbacks in one thread pool, first come first
served: a browser that sends a thousand clicks makes every other browser's callbacks
wait behind them. :class:`FairExecutor` takes that pool's place. Each task belongs to
the browser whose event it carries (:func:`client_of`); a *priority* browser (the
presenter, and the server's own tasks) is served before the others and may run several
tasks at once, as before. Every other browser runs one task at a time, in the order
it sent them, and has at most ``max_queued`` waiting: what it sends beyond that is
dropped (counted in :attr:`FairExecutor.dropped`). Browsers take turns, so a seat that
floods the server delays only itself.

Data flow::

    viser: gui/scene event of browser B -> executor.submit(callback, event)
      -> queue of B (priority: B is a presenter, or no browser)
      -> a worker takes the next task: priority queues first, then the others in turn
"""

from __future__ import annotations

__all__ = ["FairExecutor", "client_of"]

import collections
import concurrent.futures
import threading
from collections.abc import Callable, Hashable
from typing import Any

_Task = tuple[concurrent.futures.Future[Any], Callable[..., Any], tuple[Any, ...], dict]


def client_of(args: tuple[Any, ...]) -> Hashable:
    """Return the browser a viser callback's arguments come from (None: the server).

    A GUI or scene event carries ``client_id``; a camera handle carries ``client``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> client_of((SimpleNamespace(client_id=7),))
    7
    >>> client_of(()) is None
    True
    """
    if not args:
        return None
    first = args[0]
    client_id = getattr(first, "client_id", None)
    if isinstance(client_id, int):
        return client_id
    client = getattr(first, "client", None)
    client_id = getattr(client, "client_id", None)
    return client_id if isinstance(client_id, int) else None


class FairExecutor(concurrent.futures.Executor):
    """A thread pool that serves browsers fairly, priority browsers first.

    Parameters
    ----------
    workers
        Most threads (started as tasks wait, never more).
    priority
        Whether a browser's tasks go first (asked once per task; None is the server).
    max_queued
        Most tasks a non-priority browser may have waiting.
    key_of
        Which browser a task's arguments belong to.
    idle_seconds
        How long a thread waits for a task before it ends: a class that leaves gives
        its threads back.
    """

    def __init__(
        self,
        workers: int = 16,
        priority: Callable[[Hashable], bool] = lambda key: True,
        max_queued: int = 32,
        key_of: Callable[[tuple[Any, ...]], Hashable] = client_of,
        idle_seconds: float = 2.0,
    ) -> None:
        self._workers = max(1, workers)
        self._idle_seconds = idle_seconds
        self._started = 0
        self._priority = priority
        self._max_queued = max_queued
        self._key_of = key_of
        self._cond = threading.Condition()
        self._queues: dict[Hashable, collections.deque[_Task]] = {}
        self._running: collections.Counter[Hashable] = collections.Counter()
        self._first: collections.deque[Hashable] = collections.deque()  # priority
        self._turns: collections.deque[Hashable] = collections.deque()  # the others
        self._threads: list[threading.Thread] = []
        self._idle = 0
        self._shutdown = False
        self.dropped = 0
        """Tasks refused because their browser had ``max_queued`` waiting."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
        """Queue ``fn(*args, **kwargs)`` for its browser; return its future."""
        future: concurrent.futures.Future[Any] = concurrent.futures.Future()
        key = self._key_of(args)
        first = key is None or self._priority(key)
        with self._cond:
            if self._shutdown:
                raise RuntimeError("cannot schedule new futures after shutdown")
            queue = self._queues.setdefault(key, collections.deque())
            if not first and len(queue) >= self._max_queued:
                self.dropped += 1
                future.set_result(None)  # dropped quietly: nothing to print
                return future
            queue.append((future, fn, args, kwargs))
            if len(queue) == 1:
                self._enqueue(key, first)
            self._wake()
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop taking tasks; finish (or cancel) the waiting ones; join if ``wait``."""
        with self._cond:
            self._shutdown = True
            if cancel_futures:
                for queue in self._queues.values():
                    for future, *_ in queue:
                        future.cancel()
                self._queues.clear()
                self._first.clear()
                self._turns.clear()
            self._cond.notify_all()
            threads = list(self._threads)
        if wait:
            for thread in threads:
                if thread is not threading.current_thread():
                    thread.join()

    def waiting(self) -> int:
        """Return how many tasks wait (not yet started)."""
        with self._cond:
            return sum(len(q) for q in self._queues.values())

    def threads(self) -> int:
        """Return how many worker threads run now."""
        with self._cond:
            return len(self._threads)

    # ------------------------------------------------------------------ inside

    def _enqueue(self, key: Hashable, first: bool) -> None:
        # A key is in a ready line while it has tasks it may start now.
        if first:
            self._first.append(key)
        elif self._running[key] == 0:
            self._turns.append(key)

    def _wake(self) -> None:
        if self._idle > 0:
            self._cond.notify()
        elif len(self._threads) < self._workers:
            thread = threading.Thread(
                target=self._work, name=f"fair-{self._started}", daemon=True
            )
            self._started += 1
            self._threads.append(thread)
            thread.start()

    def _take(self) -> tuple[Hashable, _Task] | None:
        """Return the next task (and its key) to run, or None when there is none."""
        for line, first in ((self._first, True), (self._turns, False)):
            while line:
                key = line.popleft()
                queue = self._queues.get(key)
                if not queue:
                    continue
                task = queue.popleft()
                if not queue:
                    del self._queues[key]
                elif first:
                    line.append(key)  # priority keys take turns among themselves
                self._running[key] += 1
                return key, task
        return None

    def _work(self) -> None:
        while True:
            with self._cond:
                taken = self._take()
                while taken is None:
                    if self._shutdown:
                        return
                    self._idle += 1
                    woken = self._cond.wait(self._idle_seconds)
                    self._idle -= 1
                    taken = self._take()
                    if taken is None and not woken and not self._shutdown:
                        # Nothing to do for a while: this thread ends (a task that
                        # comes later starts another).
                        self._threads.remove(threading.current_thread())
                        return
            key, (future, fn, args, kwargs) = taken
            self._run(future, fn, args, kwargs)
            with self._cond:
                self._running[key] -= 1
                if self._running[key] == 0:
                    del self._running[key]
                # Its next task may start now (its priority may have changed meanwhile).
                lines = (self._first, self._turns)
                if self._queues.get(key) and all(key not in line for line in lines):
                    self._enqueue(key, key is None or self._priority(key))
                    self._cond.notify()

    @staticmethod
    def _run(
        future: concurrent.futures.Future[Any],
        fn: Callable[..., Any],
        args: tuple[Any, ...],
        kwargs: dict,
    ) -> None:
        if not future.set_running_or_notify_cancel():
            return
        try:
            result = fn(*args, **kwargs)
        except BaseException as error:
            future.set_exception(error)
        else:
            future.set_result(result)
