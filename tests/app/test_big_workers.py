"""Big scenes' jobs lease their worker (app.session.big): a job given up stops only its own call.

A classroom's private copies share a pool of workers for big scenes
(never one process per seat). A job interrupts the worker only while it holds it, so a
copy's edit never stops another copy's computation; a job given up before it holds a
worker never starts.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from typing import Any

from shapely import Polygon

import planners
from app.session.big import (
    BIG_SCENE_VERTICES,
    BigJob,
    OwnWorker,
    SharedWorkers,
    scene_vertices,
)
from app.session.controller import Controller
from app.session.lanes import Interrupted
from app.session.pool import WorkerPool
from tests.app.app_helpers import FakeView, wait_until
from tests.benchmarks.bench_big import circle_scene

SQUARE = Polygon([(1, 1), (2, 1), (2, 2), (1, 2)])


def _scene(goal: tuple[float, float]) -> planners.Scene:
    return planners.Scene(obstacles=(SQUARE,), start=(0.0, 0.0), goal=goal)


class FakeWorker:
    """A worker that computes until released or interrupted, and counts both."""

    def __init__(self) -> None:
        self.started: list[Any] = []
        self.interrupts = 0
        self.release = threading.Event()
        self.running = threading.Event()

    def __call__(self, scene: Any, abandoned: Any, which: tuple[str, ...]) -> Any:
        if abandoned():
            raise Interrupted("given up before it started")
        self.started.append(scene.goal)
        self.running.set()
        self.release.wait(10)
        self.running.clear()
        if abandoned():
            raise Interrupted("given up")
        return {"goal": scene.goal}

    def interrupt(self) -> None:
        self.interrupts += 1
        self.release.set()


class OnePool:
    """A pool of one worker: a lease waits until the holder hands it back or its job
    is given up (the protocol of app.session.big.BigWorkers, as app.session.pool.WorkerPool keeps it)."""

    def __init__(self, worker: FakeWorker) -> None:
        self.worker = worker
        self.held = False
        self.ready = threading.Condition()
        self.waiting = threading.Event()

    @contextlib.contextmanager
    def lease(self, abandoned: Any) -> Iterator[Any]:
        with self.ready:
            while self.held:
                if abandoned():
                    raise Interrupted("given up while waiting")
                self.waiting.set()
                self.ready.wait()
            self.held = True
        try:
            yield self.worker
        finally:
            with self.ready:
                self.held = False
                self.ready.notify_all()

    def wake(self) -> None:
        with self.ready:
            self.ready.notify_all()

    @property
    def pid(self) -> None:
        return None

    def close(self) -> None:
        pass


def _job(scene: planners.Scene, workers: Any) -> BigJob:
    return BigJob(scene.goal, scene, ("vg",), workers, lambda: None)


def test_a_job_given_up_while_waiting_never_stops_the_holders_call():
    worker = FakeWorker()
    pool = OnePool(worker)
    first = _job(_scene((3.0, 3.0)), pool)
    assert worker.running.wait(5)
    second = _job(_scene((4.0, 4.0)), pool)
    assert pool.waiting.wait(5)
    second.cancel()  # another copy's edit
    assert second.done.wait(5)  # at once: it does not wait for the worker it gave up
    assert worker.interrupts == 0 and not first.done.is_set()  # the first call goes on
    worker.release.set()
    assert first.done.wait(5)
    assert first.result == {"goal": (3.0, 3.0)} and first.error is None
    assert second.result is None and second.error is None
    assert worker.started == [(3.0, 3.0)]  # the given-up job never started


def test_a_job_given_up_while_it_computes_stops_its_worker():
    worker = FakeWorker()
    job = _job(_scene((3.0, 3.0)), OnePool(worker))
    assert worker.running.wait(5)
    job.cancel()
    assert job.done.wait(5)
    assert worker.interrupts == 1
    assert job.result is None and job.error is None


def test_a_job_given_up_after_it_ended_stops_nothing():
    worker = FakeWorker()
    worker.release.set()
    job = _job(_scene((3.0, 3.0)), OnePool(worker))
    assert job.done.wait(5)
    job.cancel()  # the next edit, once the result is in: the worker is someone else's
    assert worker.interrupts == 0
    assert job.result == {"goal": (3.0, 3.0)}


def test_a_sessions_own_worker_is_leased_as_itself():
    worker = FakeWorker()
    worker.release.set()
    own = OwnWorker(worker)  # type: ignore[arg-type]
    with own.lease(lambda: False) as held:
        assert held is worker
    job = _job(_scene((3.0, 3.0)), own)
    assert job.done.wait(5) and job.result == {"goal": (3.0, 3.0)}


def test_closing_a_session_gives_its_big_job_up_and_the_worker_back():
    """A classroom copy closing while its big scene computes in the shared pool: the
    job is cancelled at once, and the pool's worker is free for the other copies."""
    worker = FakeWorker()
    pool = OnePool(worker)
    scene = planners.load_scene(circle_scene())
    assert scene_vertices(scene) > BIG_SCENE_VERTICES
    controller = Controller(
        FakeView(), scene, big_workers=pool, slow_plan=lambda s: {}, slow_names=()
    )
    try:
        assert worker.running.wait(30)  # the fast lane's job holds the worker
    finally:
        controller.close()
    assert worker.interrupts == 1
    assert wait_until(lambda: not pool.held, 10)


def slow_answer(scene: planners.Scene, memo: Any = None, which: Any = ()) -> Any:
    """A worker's function that computes for goal.x seconds (a big scene's stand-in)."""
    time.sleep(scene.goal[0])
    return {"goal": scene.goal}


def test_in_a_real_pool_jobs_given_up_while_waiting_end_at_once():
    """A student drags a big scene while another copy's computation holds the only
    worker: each edit gives a job up; none of them waits for the worker (threads and
    scenes would pile up, one per edit), and the holder's call goes on to its result."""
    pool = WorkerPool(slow_answer, size=1)
    workers = SharedWorkers(pool)
    try:
        holder = _job(_scene((3.0, 3.0)), workers)
        assert wait_until(lambda: pool.processes == 1, 10)  # the holder has it
        dragged = [_job(_scene((0.1 * k, 9.0)), workers) for k in range(1, 6)]
        assert wait_until(lambda: pool.waiting == 5, 10)  # each waits for the worker
        for job in dragged:
            job.cancel()
        assert all(job.done.wait(2.0) for job in dragged)
        assert all(job.result is None and job.error is None for job in dragged)
        assert not holder.done.is_set()  # still computing: nobody interrupted it
        assert holder.done.wait(30)
        assert holder.result == {"goal": (3.0, 3.0)} and holder.error is None
        # The worker went back to the pool: the next job gets it.
        after = _job(_scene((0.0, 1.0)), workers)
        assert after.done.wait(30) and after.result == {"goal": (0.0, 1.0)}
        assert pool.processes == 1
    finally:
        pool.close()


def test_closing_a_pool_ends_the_leases_that_wait():
    """The classroom closes while a copy's job waits for the only worker (held, with no
    call running that could hand it back): the wait ends with the pool's error."""
    pool = WorkerPool(slow_answer, size=1)
    workers = SharedWorkers(pool)
    with pool.lease():  # another copy holds the worker
        waiting = _job(_scene((0.0, 1.0)), workers)
        assert wait_until(lambda: pool.waiting == 1, 10)
        pool.close()
        assert waiting.done.wait(5)
    assert waiting.result is None
    assert isinstance(waiting.error, RuntimeError)
    assert "pool is closed" in str(waiting.error)
