"""What sessions share: pools of worker processes, turns, a ticker for their robots.

Each session of the presenter's kind has worker processes of its own: one for TangentBug
(:mod:`app.session.lanes`), one for a big scene's graphs (:mod:`app.session.big`, started on first use).
A classroom may hold dozens of private copies; processes of their own would grow without
bound (about 60 MB and a start-up of a second or so each, and a big scene's planning some
hundreds of MB more). The copies share two pools instead, one for each kind of work: at
most ``size`` processes each, started on first use, each answering one call at a time; a
call waits for a free worker. A worker's :class:`planners.Memo` then sees scenes of
several sessions in turn: that only costs reuse, never correctness (the planners are
pure and the memo is keyed on the values it caches).

Data flow::

    private session's slow lane (its scheduler thread)
      -> pool(scene, which)         # wait for a free worker (the idle ones)
           worker(scene, which=...) # one ProcessLane: pickles out, result back
      -> the worker goes back to the idle ones
    private session's big scene (a BigJob's thread)
      -> with pool.lease(abandoned) as worker: worker(scene, ...)  # interrupted if given up
         given up while it waits: pool.wake() -> the lease ends at once (Interrupted)
    robot animation, live robot (Ticking: due, tick) -> ticker.add(run)
      ticker's thread: the earliest due run, if due and the rate allows: run.tick()
      (one step, drawn); else wait until the next is due, or a wake (a run started)
"""

from __future__ import annotations

__all__ = ["Runner", "Ticker", "Ticking", "Turns", "WorkerPool"]

import collections
import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any, Protocol

from app.session.lanes import Interrupted, ProcessLane

logger = logging.getLogger(__name__)


class WorkerPool:
    """At most ``size`` :class:`app.session.lanes.ProcessLane` workers computing ``fn``, shared.

    Parameters
    ----------
    fn
        A picklable function ``fn(scene, memo=..., which=...)`` (as for a
        :class:`ProcessLane`).
    size
        Most processes ever running at once (at least 1).
    nice
        The workers' priority below this process's (:class:`ProcessLane`).
    """

    def __init__(self, fn: Callable[..., Any], size: int = 1, nice: int = 0) -> None:
        self._fn = fn
        self._nice = nice
        self.size = max(1, int(size))
        """Most worker processes at once."""
        # Guarded by the condition: the idle workers, every worker, closed or not.
        self._ready = threading.Condition()
        self._idle: list[ProcessLane] = []
        self._all: list[ProcessLane] = []
        # Who waits for a worker, in order of arrival:
        self._line: collections.deque[object] = collections.deque()
        self._closed = False

    def __call__(self, scene: Any, which: tuple[str, ...]) -> Any:
        """Compute ``fn(scene, which=which)`` on a free worker (waiting for one)."""
        with self.lease() as worker:
            return worker(scene, which=which)

    @contextlib.contextmanager
    def lease(
        self, abandoned: Callable[[], bool] | None = None
    ) -> Iterator[ProcessLane]:
        """Hold a free worker (waiting for one) for the caller alone until the block ends.

        The caller may :meth:`app.session.lanes.ProcessLane.interrupt` it while it holds it (a
        big scene's job given up, :mod:`app.session.big`): its process is replaced by a fresh
        one at once, and the worker goes back to the pool as usual.

        ``abandoned`` (optional) tells whether the caller has given up: one that gives up
        while it waits calls :meth:`wake`, and the lease raises
        :class:`app.session.lanes.Interrupted` at once instead of waiting for a worker only to
        hand it back (a student dragging a big scene gives a job up per edit).
        """
        worker = self._take(abandoned or _never)
        try:
            yield worker
        finally:
            with self._ready:
                self._idle.append(worker)
                self._ready.notify_all()

    def wake(self) -> None:
        """Have the leases that wait ask their ``abandoned`` again."""
        with self._ready:
            self._ready.notify_all()

    def _take(self, abandoned: Callable[[], bool]) -> ProcessLane:
        """Return a free worker, first come first served.

        A session that asks again waits behind the others: copies share the workers in
        turns.
        """
        ticket = object()
        with self._ready:
            self._line.append(ticket)
            try:
                while True:
                    if self._closed:
                        raise RuntimeError("the worker pool is closed")
                    if abandoned():
                        raise Interrupted("given up while waiting for a worker")
                    if self._line[0] is ticket:
                        if self._idle:
                            return self._idle.pop()
                        if len(self._all) < self.size:
                            worker = ProcessLane(self._fn, nice=self._nice)
                            self._all.append(worker)
                            return worker
                    self._ready.wait()
            finally:
                self._line.remove(ticket)
                self._ready.notify_all()  # the next in line may go

    @property
    def waiting(self) -> int:
        """Leases waiting for a free worker right now."""
        with self._ready:
            return len(self._line)

    @property
    def processes(self) -> int:
        """Worker processes started so far (never more than :attr:`size`)."""
        with self._ready:
            return len(self._all)

    @property
    def pids(self) -> list[int]:
        """Process ids of the workers started so far."""
        with self._ready:
            return [w.pid for w in self._all if w.pid is not None]

    def close(self) -> None:
        """Stop every worker: a call in progress and a lease that waits end with errors."""
        with self._ready:
            self._closed = True
            workers, self._all = self._all, []
            self._ready.notify_all()
        for worker in workers:
            worker.close()


def _never() -> bool:
    """Nobody gives this lease up."""
    return False


class Turns:
    """The copies' turns in the server's own process: one at a time, at most ``rate`` a second.

    A copy plans in the shared pools, but builds its frames and draws them (its own view,
    its panel, its robot's trajectory) in the interpreter that serves the presenter.
    Each round of a copy takes a turn: first come first served, one at a time, and the
    turns start at most ``rate`` times a second in all, so ten students dragging cost the
    presenter a bounded share of the interpreter, whatever they do. A copy that waits
    for its turn coalesces its edits meanwhile: its round draws its newest scene.

    Parameters
    ----------
    rate
        Most turns a second, all copies together.
    """

    def __init__(self, rate: float) -> None:
        self._period = 1.0 / rate
        self._cond = threading.Condition()
        self._line: collections.deque[object] = collections.deque()
        self._busy = False
        self._next_at = 0.0  # time.monotonic() when the next turn may start

    @contextlib.contextmanager
    def turn(self, abandoned: Callable[[], bool] = lambda: False) -> Iterator[None]:
        """Hold the turn for the block; :class:`Interrupted` if ``abandoned`` while waiting."""
        ticket = object()
        with self._cond:
            self._line.append(ticket)
            try:
                while True:
                    if abandoned():
                        raise Interrupted("given up while waiting for a turn")
                    wait = 0.1  # abandoned() is asked again at least this often [s]
                    if self._line[0] is ticket and not self._busy:
                        now = time.monotonic()
                        if now >= self._next_at:
                            self._busy = True
                            self._next_at = now + self._period
                            break
                        wait = self._next_at - now
                    self._cond.wait(wait)
            finally:
                self._line.remove(ticket)
                self._cond.notify_all()
        try:
            yield
        finally:
            with self._cond:
                self._busy = False
                self._cond.notify_all()

    @property
    def waiting(self) -> int:
        """Copies waiting for their turn right now."""
        with self._cond:
            return len(self._line)


class Ticking(Protocol):
    """What a :class:`Ticker` steps."""

    def due(self) -> float | None:
        """When the next step is due [``time.monotonic()`` s]; None while stopped."""
        ...

    def tick(self) -> None:
        """Take one step now (the ticker's thread; never raises)."""
        ...


class Ticker:
    """Step runs when they are due, from one thread, at most ``rate`` steps a second.

    A run is anything :class:`Ticking`: the robot's animation
    (:class:`app.session.playback.Playback`), the live robot (:class:`app.live.LiveRun`).
    A session's runs have a ticker each (``rate`` None: every step on time). A
    classroom's copies share one with a rate: ten students playing or driving robots
    cost the presenter one thread and a bounded share of the interpreter; each of their
    robots is then drawn less often. Runs due together step earliest first. The thread
    runs while a run has steps to take: it ends after ``idle`` seconds with none due,
    and a run that starts (:meth:`wake`) or joins starts it again.

    Parameters
    ----------
    rate
        Most steps a second, all runs together; None for no bound.
    name
        Its thread's name.
    idle
        Its thread ends after this long with no run due [s].
    """

    def __init__(
        self, rate: float | None = None, name: str = "ticker", idle: float = 2.0
    ) -> None:
        self._period = 0.0 if rate is None else 1.0 / rate
        self._name = name
        self._idle = idle
        self._cond = threading.Condition()
        self._runs: list[Ticking] = []
        self._woken = False
        self._closed = False
        self._thread: threading.Thread | None = None
        self._stepping: Ticking | None = None  # the run taking a step now

    def add(self, run: Ticking) -> None:
        """Step ``run`` from now on (its thread starts if it was not running)."""
        with self._cond:
            if self._closed:
                raise RuntimeError("the ticker is closed")
            self._runs.append(run)
            self._wake_locked()

    def remove(self, run: Ticking, timeout: float = 5.0) -> None:
        """Step ``run`` no more; wait (at most ``timeout`` s) for a step it is taking."""
        deadline = time.monotonic() + timeout
        with self._cond:
            self._runs = [r for r in self._runs if r is not run]
            self._woken = True
            self._cond.notify_all()
            if self._thread is threading.current_thread():
                return  # asked by the run's own step
            while self._stepping is run and time.monotonic() < deadline:
                self._cond.wait(0.05)

    def wake(self) -> None:
        """Look at the runs again (one has just started)."""
        with self._cond:
            self._wake_locked()

    def _wake_locked(self) -> None:
        """Have the thread look at the runs again; start it if it ended."""
        self._woken = True
        self._cond.notify_all()
        if self._thread is None and not self._closed and self._runs:
            self._thread = threading.Thread(
                target=self._loop, name=self._name, daemon=True
            )
            self._thread.start()

    def close(self) -> None:
        """Stop every run's stepping and end the thread."""
        with self._cond:
            self._closed = True
            self._runs = []
            self._cond.notify_all()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    @property
    def alive(self) -> bool:
        """Whether its thread runs (a run had a step due within the last ``idle`` s)."""
        with self._cond:
            return self._thread is not None

    def _loop(self) -> None:
        last = -math.inf
        while True:
            with self._cond:
                if self._closed or not self._runs:
                    self._thread = None
                    self._cond.notify_all()
                    return
                runs, self._woken = list(self._runs), False
            now = time.monotonic()
            due = sorted(
                (
                    (t, k, run)
                    for k, run in enumerate(runs)
                    if (t := run.due()) is not None
                ),
                key=lambda d: d[:2],
            )
            wait = None if not due else due[0][0] - now
            if due and wait is not None and wait <= 0:
                wait = last + self._period - now
                if wait <= 0:
                    with self._cond:
                        if due[0][2] not in self._runs:
                            continue  # removed meanwhile
                        self._stepping = due[0][2]
                    try:
                        due[0][2].tick()
                    finally:
                        with self._cond:
                            self._stepping = None
                            self._cond.notify_all()
                    last = time.monotonic()
                    continue
            with self._cond:
                if self._woken or self._closed or not self._runs:
                    continue
                if wait is None and not self._cond.wait(self._idle) and not self._woken:
                    self._thread = None  # nothing due: a wake starts it again
                    self._cond.notify_all()
                    return
                if wait is not None:
                    self._cond.wait(wait)


class Runner:
    """Run the jobs of many sessions on at most ``threads`` shared threads.

    A classroom's copies hold no threads of their own: each copy's scheduler hands its
    rounds and its slow lane's calls to runners every copy shares
    (:class:`app.session.scheduler.Scheduler`, ``runners``). A job is a callable that
    does at most one piece of work and returns. :meth:`wake` asks for a job to run once
    more: a job already waiting keeps its place, a job running now runs again after.
    Jobs run in the order they were woken, never two runs of one job at once. The
    threads start when there is work and end after ``idle`` seconds without.

    Parameters
    ----------
    threads
        Most jobs running at once.
    name
        Its threads' name.
    idle
        A thread with nothing to do for this long ends [s].
    """

    def __init__(self, threads: int = 1, name: str = "runner", idle: float = 2.0):
        self._size = max(1, int(threads))
        self._name = name
        self._idle = idle
        self._cond = threading.Condition()
        self._pending: dict[Callable[[], None], None] = {}  # in order of waking
        self._running: dict[Callable[[], None], threading.Thread] = {}
        self._threads: set[threading.Thread] = set()
        self._waiting = 0  # threads with nothing to do
        self._closed = False

    def wake(self, job: Callable[[], None]) -> None:
        """Run ``job`` once more (soon, in its turn)."""
        with self._cond:
            if self._closed:
                return
            self._pending.setdefault(job, None)
            if self._waiting == 0 and len(self._threads) < self._size:
                thread = threading.Thread(
                    target=self._loop, name=self._name, daemon=True
                )
                self._threads.add(thread)
                thread.start()
            self._cond.notify()

    def forget(self, job: Callable[[], None], timeout: float = 5.0) -> None:
        """Run ``job`` no more; wait (at most ``timeout`` s) for a run in progress."""
        deadline = time.monotonic() + timeout
        with self._cond:
            self._pending.pop(job, None)
            while self._running.get(job) not in (None, threading.current_thread()):
                left = deadline - time.monotonic()
                if left <= 0:
                    return
                self._cond.wait(left)

    @property
    def threads(self) -> int:
        """Threads running now."""
        with self._cond:
            return len(self._threads)

    def close(self) -> None:
        """Run nothing more; wait for the jobs running now to end."""
        with self._cond:
            self._closed = True
            self._pending.clear()
            self._cond.notify_all()
            threads = list(self._threads)
        for thread in threads:
            if thread is not threading.current_thread():
                thread.join(timeout=5.0)

    def _next_locked(self) -> Callable[[], None] | None:
        return next((j for j in self._pending if j not in self._running), None)

    def _loop(self) -> None:
        me = threading.current_thread()
        while True:
            with self._cond:
                job = self._next_locked()
                while job is None:
                    if self._closed:
                        self._threads.discard(me)
                        return
                    self._waiting += 1
                    woken = self._cond.wait(self._idle)
                    self._waiting -= 1
                    job = self._next_locked()
                    if job is None and not woken:
                        self._threads.discard(me)  # idle: the next wake starts one
                        return
                del self._pending[job]
                self._running[job] = me
            try:
                job()
            except Exception:  # one session's failure stops no other's
                logger.exception("a shared job failed")
            finally:
                with self._cond:
                    del self._running[job]
                    self._cond.notify_all()
