"""The runner that the classroom's copies share instead of threads of their own.

Held here: jobs run in the order they were woken, a job woken while it waits keeps its
place, a job woken while it runs runs again after (no wake is lost), one job never runs
twice at once, at most ``threads`` run together, threads end when idle, a failing job
stops no other, and ``forget`` waits for a run in progress.
"""

from __future__ import annotations

import threading
import time

from hypothesis import given, settings
from hypothesis import strategies as st

from app.session.pool import Runner
from tests.app.app_helpers import wait_until


def _threads(name: str) -> int:
    return sum(t.name == name for t in threading.enumerate())


def test_jobs_run_in_the_order_they_were_woken_and_a_waiting_one_once():
    runner = Runner(1, name="test-runner")
    order: list[str] = []
    gate = threading.Event()
    try:

        def hold() -> None:  # holds the one thread
            gate.wait(10)

        runner.wake(hold)
        jobs = {name: (lambda name=name: order.append(name)) for name in "abc"}
        for name in "abcab":  # a and b again while they wait: they keep their place
            runner.wake(jobs[name])
        gate.set()
        assert wait_until(lambda: len(order) == 3, 20)
        time.sleep(0.05)
        assert order == ["a", "b", "c"]
    finally:
        runner.close()


def test_a_job_woken_while_it_runs_runs_again_after():
    runner = Runner(2, name="test-runner")
    started, release = threading.Event(), threading.Event()
    runs: list[float] = []

    def job() -> None:
        runs.append(time.monotonic())
        started.set()
        release.wait(10)

    try:
        runner.wake(job)
        assert started.wait(10)
        woken = time.monotonic()
        runner.wake(job)  # while it runs: once more, after, not beside it
        time.sleep(0.1)
        assert len(runs) == 1
        release.set()
        assert wait_until(lambda: len(runs) == 2, 20)
        assert runs[1] > woken
    finally:
        release.set()
        runner.close()


@settings(max_examples=20, deadline=None)
@given(
    wakes=st.lists(st.integers(0, 3), min_size=1, max_size=30),
    threads=st.integers(1, 3),
)
def test_no_wake_is_lost_and_no_job_runs_twice_at_once(wakes, threads):
    """Against the plain rule: after the last wake of a job, it starts once more."""
    runner = Runner(threads, name="test-runner")
    lock = threading.Lock()
    running: dict[int, int] = dict.fromkeys(range(4), 0)
    most = {"jobs": 0, "same": 0}
    last_start: dict[int, float] = {}
    together = [0]

    def make(k: int):
        def job() -> None:
            with lock:
                running[k] += 1
                together[0] += 1
                most["same"] = max(most["same"], running[k])
                most["jobs"] = max(most["jobs"], together[0])
                last_start[k] = time.monotonic()
            time.sleep(0.001)
            with lock:
                running[k] -= 1
                together[0] -= 1

        return job

    jobs = [make(k) for k in range(4)]
    last_wake: dict[int, float] = {}
    try:
        for k in wakes:
            last_wake[k] = time.monotonic()
            runner.wake(jobs[k])
        for k, woken in last_wake.items():
            assert wait_until(lambda k=k, w=woken: last_start.get(k, -1.0) >= w, 20)
        assert most["same"] == 1
        assert most["jobs"] <= threads
        assert runner.threads <= threads
    finally:
        runner.close()


def test_threads_end_when_idle_and_a_failing_job_stops_no_other():
    runner = Runner(2, name="test-runner-idle", idle=0.1)
    done: list[int] = []
    try:
        assert runner.threads == 0 and _threads("test-runner-idle") == 0

        def broken() -> None:
            raise RuntimeError("a copy's bug")

        runner.wake(broken)
        runner.wake(lambda: done.append(1))
        assert wait_until(lambda: done == [1], 20)
        assert wait_until(lambda: _threads("test-runner-idle") == 0, 20)
        assert runner.threads == 0
        runner.wake(lambda: done.append(2))  # a new wake starts a thread again
        assert wait_until(lambda: done == [1, 2], 20)
    finally:
        runner.close()


def test_forget_waits_for_a_run_in_progress_and_drops_a_waiting_one():
    runner = Runner(1, name="test-runner")
    started, finished = threading.Event(), threading.Event()
    later: list[int] = []

    def slow() -> None:
        started.set()
        time.sleep(0.2)
        finished.set()

    try:
        runner.wake(slow)
        assert started.wait(10)
        runner.wake(slow)  # waits behind its own run
        waiting = lambda: later.append(1)  # noqa: E731 - a job is a plain callable
        runner.wake(waiting)
        runner.forget(waiting)
        runner.forget(slow)
        assert finished.is_set()  # forget returned after the run ended
        time.sleep(0.3)
        assert later == []
    finally:
        runner.close()
