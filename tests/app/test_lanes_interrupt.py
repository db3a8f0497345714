"""ProcessLane: a call given up ends at once, the lane keeps working; workers freeze."""

from __future__ import annotations

import gc
import threading
import time
from typing import Any

import pytest

from app import server
from app.session.lanes import Interrupted, ProcessLane


def slow_echo(value: Any, memo: Any = None, seconds: float = 0.0) -> Any:
    """Return ``value`` after ``seconds`` (run in the worker process)."""
    time.sleep(seconds)
    return value


def test_an_interrupted_call_raises_and_the_next_one_is_answered():
    lane = ProcessLane(slow_echo, start=False)
    try:
        assert lane.pid is None  # started on first use
        given_up = threading.Event()
        outcome: list[BaseException | Any] = []

        def call() -> None:
            try:
                outcome.append(lane(1, abandoned=given_up.is_set, seconds=60.0))
            except BaseException as error:
                outcome.append(error)

        thread = threading.Thread(target=call)
        thread.start()
        deadline = time.monotonic() + 30
        while lane.pid is None and time.monotonic() < deadline:
            time.sleep(0.01)
        first = lane.pid
        time.sleep(0.5)  # the worker is inside the minute-long call
        given_up.set()
        lane.interrupt()
        thread.join(timeout=30)
        assert not thread.is_alive()
        assert len(outcome) == 1 and isinstance(outcome[0], Interrupted)
        # A fresh worker answers the next call (never the given-up one's result).
        assert lane.pid is not None and lane.pid != first
        assert lane(2, seconds=0.0) == 2
    finally:
        lane.close()


def test_a_call_given_up_before_it_starts_never_runs():
    lane = ProcessLane(slow_echo, start=False)
    try:
        with pytest.raises(Interrupted):
            lane(3, abandoned=lambda: True, seconds=60.0)
        assert lane.pid is None
    finally:
        lane.close()


def test_a_worker_that_dies_on_its_own_is_still_restarted():
    lane = ProcessLane(slow_echo)
    try:
        assert lane(4) == 4
        lane.interrupt()  # nobody gave a call up: the next call just uses the new one
        assert lane(5, abandoned=lambda: False) == 5
    finally:
        lane.close()


def test_close_while_an_interrupt_restarts_the_worker_leaves_no_worker(monkeypatch):
    # Review finding: interrupt() restarting the worker while close() ran could start a
    # worker after close that lived until the app's process ended.
    lane = ProcessLane(slow_echo, start=False)
    starting = threading.Event()
    real_start = ProcessLane._start

    def slow_start(self: ProcessLane) -> None:
        starting.set()
        time.sleep(0.5)  # close() arrives while the restart is under way
        real_start(self)

    monkeypatch.setattr(ProcessLane, "_start", slow_start)
    restart = threading.Thread(target=lane.interrupt)
    restart.start()
    assert starting.wait(30)
    lane.close()
    restart.join(timeout=30)
    assert not restart.is_alive()
    assert lane.pid is None  # the restart finished first, then close() stopped it
    lane.interrupt()  # an interrupt after close starts nothing
    assert lane.pid is None


def frozen_count(value: Any, memo: Any = None) -> int:
    """Return how many objects the worker has frozen (run in the worker process)."""
    return gc.get_freeze_count()


def test_a_worker_freezes_its_long_lived_objects_after_its_first_answer():
    # A full collection in the worker would walk its imports (numba's are 100,000s of
    # objects, 50 ms): after the first answer they leave the collector's sight.
    lane = ProcessLane(frozen_count)
    try:
        assert lane(None) == 0
        assert lane(None) > 10_000
    finally:
        lane.close()


def test_the_app_freezes_its_long_lived_objects_once_warmed_up(monkeypatch):
    # The warm-up thread's order: load numba and the compiled loops, then freeze them.
    calls = []
    monkeypatch.setattr(server, "warm_up", lambda: calls.append("warm_up"))
    monkeypatch.setattr(
        server, "freeze_long_lived", lambda: calls.append("freeze") or 1
    )
    server._warm_up()
    assert calls == ["warm_up", "freeze"]


def kernels_ready(value: Any, memo: Any = None, wait: float = 30.0) -> int:
    """Return how many signatures the sweep has compiled, once the warm-up is done."""
    deadline = time.monotonic() + wait
    warming = [t for t in threading.enumerate() if t.name == "warm-up"]
    for thread in warming:
        thread.join(max(0.0, deadline - time.monotonic()))
    from planners import kernels

    return len(kernels.sweep_intervals.signatures)


def test_a_worker_loads_the_compiled_loops_before_its_first_scene():
    # TangentBug's first sweep in a fresh worker (after a restart, in the students'
    # pool) would otherwise load numba and the loops first: about 0.3 s.
    lane = ProcessLane(kernels_ready)
    try:
        assert lane(None) == 1
    finally:
        lane.close()
