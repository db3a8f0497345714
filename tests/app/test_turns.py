"""The copies' shares of the server (app.session.pool): turns in order, at a bounded rate.

:class:`Turns` is held to what a classroom relies on: one copy's round at a time, in the
order they asked, never more turns than its rate in any stretch of time, and a copy that
closes while it waits leaves at once. A :class:`WorkerPool` serves its callers first
come, first served.
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable

import pytest

from app.session.lanes import Interrupted
from app.session.pool import Turns, WorkerPool
from app.session.scheduler import default_plan
from tests.app.app_helpers import wait_until


def _queue_in_order(
    n: int,
    enter: Callable[[int], None],
    waiting: Callable[[], int],
    record: list[int],
) -> list[threading.Thread]:
    """Start ``n`` threads that call ``enter(k)``, each once the previous one waits
    (or got in: ``record``), so they ask in the order 0, 1, 2..."""
    threads = []
    for k in range(n):
        thread = threading.Thread(target=enter, args=(k,))
        thread.start()
        threads.append(thread)
        assert wait_until(lambda k=k: len(record) + waiting() >= k + 1, 10)
    return threads


def test_turns_go_one_at_a_time_in_the_order_asked():
    turns = Turns(rate=1000.0)
    order: list[int] = []
    inside, most = [0], [0]
    lock = threading.Lock()
    gate = threading.Event()

    def take(k: int) -> None:
        with turns.turn():
            with lock:
                inside[0] += 1
                most[0] = max(most[0], inside[0])
                order.append(k)
            if k == 0:
                gate.wait(10)  # the first holds its turn while the others line up
            with lock:
                inside[0] -= 1

    threads = _queue_in_order(5, take, lambda: turns.waiting, order)
    assert wait_until(lambda: turns.waiting == 4, 10)
    gate.set()
    for thread in threads:
        thread.join(10)
    assert order == [0, 1, 2, 3, 4]
    assert most[0] == 1


def test_turns_start_no_faster_than_their_rate():
    rate, n = 50.0, 11
    turns = Turns(rate)
    starts: list[float] = []
    for _ in range(n):
        with turns.turn():
            starts.append(time.monotonic())
    # Ten gaps of at least 1/rate each (a lower bound: a slow machine only adds).
    assert starts[-1] - starts[0] >= (n - 1) / rate - 1e-3


def test_a_copy_that_closes_while_it_waits_leaves_at_once():
    turns = Turns(rate=1000.0)
    closed = threading.Event()
    held = threading.Event()
    release = threading.Event()
    outcome: list[str] = []

    def holder() -> None:
        with turns.turn():
            held.set()
            release.wait(10)

    def waiter() -> None:
        try:
            with turns.turn(closed.is_set):
                outcome.append("granted")
        except Interrupted:
            outcome.append("interrupted")

    first = threading.Thread(target=holder)
    first.start()
    assert held.wait(10)
    second = threading.Thread(target=waiter)
    second.start()
    assert wait_until(lambda: turns.waiting == 1, 10)
    closed.set()
    second.join(5)
    assert outcome == ["interrupted"] and turns.waiting == 0
    release.set()
    first.join(5)
    with turns.turn():  # the turn is free again
        pass


@pytest.fixture
def pool():
    fast = WorkerPool(functools.partial(default_plan, which=("vg",)), size=1, nice=5)
    yield fast
    fast.close()


def test_a_pool_serves_its_callers_first_come_first_served(pool):
    order: list[int] = []

    def lease(k: int) -> None:
        with pool.lease():
            order.append(k)

    with pool.lease():
        threads = _queue_in_order(4, lease, lambda: pool.waiting, order)
        assert wait_until(lambda: pool.waiting == 4, 10)
    for thread in threads:
        thread.join(10)
    assert order == [0, 1, 2, 3]
    assert pool.processes == 1
