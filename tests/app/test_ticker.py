"""The live robots' ticker: due runs step earliest first, within a shared rate, on one thread.

The runs here are stand-ins with the two methods a ticker calls (``due``, ``tick``), so
what is held is the ticker's: its bound, its fairness, its thread's life.
"""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any, cast

from app.session.pool import Ticker, Ticking
from tests.app.app_helpers import wait_until


class _Run:
    """Always wants a step every ``period`` seconds, as a :class:`LiveRun` does."""

    def __init__(self, period: float = 0.05) -> None:
        self.period = period
        self.next = time.monotonic()
        self.ticks: list[float] = []
        self.stopped = False

    def due(self) -> float | None:
        return None if self.stopped else self.next

    def tick(self) -> None:
        now = time.monotonic()
        self.ticks.append(now)
        self.next = max(self.next + self.period, now - self.period)


def _add(ticker: Ticker, run: _Run) -> None:
    ticker.add(cast(Ticking, run))


def test_runs_share_the_rate_and_take_turns():
    rate = 30.0
    ticker = Ticker(rate, name="test-ticker")
    runs = [_Run() for _ in range(3)]  # 60 steps a second wanted, 30 allowed
    try:
        begin = time.monotonic()
        for run in runs:
            _add(ticker, run)
        assert wait_until(lambda: sum(len(r.ticks) for r in runs) >= 30, 20)
        for run in runs:
            ticker.remove(cast(Ticking, run))
        elapsed = time.monotonic() - begin
        ticks = sorted(t for r in runs for t in r.ticks)
        # Never faster than the rate: consecutive steps at least a period apart.
        gaps = [b - a for a, b in itertools.pairwise(ticks)]
        assert min(gaps) >= 1 / rate - 1e-3, min(gaps)
        assert len(ticks) <= rate * elapsed + 1
        # Earliest due first: every run gets its share, none more than one step ahead.
        counts = [len(r.ticks) for r in runs]
        assert max(counts) - min(counts) <= 1, counts
    finally:
        ticker.close()


def test_a_stopped_run_is_not_stepped_and_a_removed_one_never_again():
    ticker = Ticker(name="test-ticker")
    run, idle = _Run(period=0.01), _Run()
    idle.stopped = True
    try:
        _add(ticker, idle)
        _add(ticker, run)
        assert wait_until(lambda: len(run.ticks) >= 5, 20)
        ticker.remove(cast(Ticking, run))
        count = len(run.ticks)
        time.sleep(0.1)
        assert len(run.ticks) == count
        assert idle.ticks == []
    finally:
        ticker.close()


def test_its_thread_runs_only_while_a_run_is_due():
    ticker = Ticker(20.0, name="test-ticker", idle=0.1)

    def threads() -> list[Any]:
        return [t for t in threading.enumerate() if t.name == "test-ticker"]

    try:
        assert not ticker.alive and not threads()
        first, second = _Run(), _Run()
        _add(ticker, first)
        _add(ticker, second)
        assert ticker.alive and len(threads()) == 1  # one thread for every run
        first.stopped = second.stopped = True  # nothing due: it ends when idle
        assert wait_until(lambda: not ticker.alive and not threads(), 20)
        count = len(first.ticks)
        first.stopped = False
        ticker.wake()  # a run starts again: so does the thread
        assert wait_until(lambda: len(first.ticks) >= count + 2, 20)
        assert len(threads()) == 1
        ticker.remove(cast(Ticking, first))
        ticker.remove(cast(Ticking, second))
        assert wait_until(lambda: not ticker.alive and not threads(), 20)
        _add(ticker, first)  # a new run starts it again
        assert wait_until(lambda: len(first.ticks) >= count + 4, 20)
    finally:
        ticker.close()
    assert wait_until(lambda: not threads(), 20)
