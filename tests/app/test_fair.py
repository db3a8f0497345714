"""The fair callback pool (app.guard.fair) and the door's checks (app.guard.door), without a server.

The pool is held to a plain reference: every task not dropped runs exactly once, a
browser's tasks run in the order it sent them and one at a time, a priority browser is
never left waiting behind the others, and a browser's waiting tasks are bounded.
"""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import pytest
import viser
from hypothesis import given, settings
from hypothesis import strategies as st

from app.guard.door import Bucket, offers
from app.guard.fair import FairExecutor, client_of


def _event(client_id):
    return SimpleNamespace(client_id=client_id)


def test_a_browsers_tasks_run_in_order_one_at_a_time():
    pool = FairExecutor(workers=4, priority=lambda key: False)
    running, most, order = [0], [0], []
    lock = threading.Lock()

    def task(event, k):
        with lock:
            running[0] += 1
            most[0] = max(most[0], running[0])
        time.sleep(0.002)
        with lock:
            running[0] -= 1
            order.append(k)

    futures = [pool.submit(task, _event(7), k) for k in range(20)]
    for f in futures:
        f.result(timeout=10)
    pool.shutdown()
    assert order == list(range(20)) and most[0] == 1


def test_the_presenter_goes_before_a_flooding_seat():
    gate = threading.Event()
    pool = FairExecutor(workers=1, priority=lambda key: key == 1, max_queued=1000)
    done = []
    started = threading.Event()
    pool.submit(lambda e: (started.set(), gate.wait(10)), _event(2))
    assert started.wait(10)  # the one worker is busy
    for k in range(200):
        pool.submit(lambda e, k=k: done.append(("seat", k)), _event(2))
    presenter = pool.submit(lambda e: done.append(("presenter", 0)), _event(1))
    gate.set()
    presenter.result(timeout=10)
    assert done[0] == ("presenter", 0)
    pool.shutdown()


def test_idle_threads_end_and_a_later_task_starts_one_again():
    """A class that leaves gives its threads back; the pool still serves the next."""
    pool = FairExecutor(workers=4, priority=lambda key: False, idle_seconds=0.05)
    gate = threading.Event()
    futures = [pool.submit(lambda event: gate.wait(), _event(k)) for k in range(4)]
    deadline = time.monotonic() + 10
    while pool.threads() < 4 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert pool.threads() == 4
    gate.set()
    for f in futures:
        f.result(timeout=10)
    while pool.threads() > 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert pool.threads() == 0
    assert not [t for t in threading.enumerate() if t.name.startswith("fair-")]
    assert pool.submit(lambda event: event.client_id * 2, _event(21)).result(10) == 42
    pool.shutdown()


def test_a_seats_waiting_tasks_are_bounded_and_dropped_quietly():
    gate, started = threading.Event(), threading.Event()
    pool = FairExecutor(workers=1, priority=lambda key: False, max_queued=5)
    pool.submit(lambda e: (started.set(), gate.wait(10)), _event(3))
    assert started.wait(10)
    futures = [pool.submit(lambda e: None, _event(3)) for _ in range(50)]
    assert pool.dropped == 45  # one runs, five wait, the rest are dropped
    assert all(f.done() for f in futures[5:])
    gate.set()
    for f in futures:
        assert f.result(timeout=10) is None
    pool.shutdown()


def test_a_failing_task_reports_its_error_and_the_pool_goes_on():
    pool = FairExecutor(workers=2)
    bad = pool.submit(lambda: 1 / 0)
    good = pool.submit(lambda: 42)
    with pytest.raises(ZeroDivisionError):
        bad.result(timeout=10)
    assert good.result(timeout=10) == 42
    pool.shutdown()
    with pytest.raises(RuntimeError):
        pool.submit(lambda: 0)


def test_the_browser_of_a_callback():
    camera = SimpleNamespace(client=SimpleNamespace(client_id=4))
    assert client_of((camera,)) == 4
    assert client_of((object(),)) is None


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 4), st.integers(0, 3)), min_size=1, max_size=60),
    st.integers(1, 4),
    st.sampled_from([2.0, 0.0005]),
)
def test_every_task_runs_once_in_its_browsers_order(tasks, workers, idle):
    """Against the obvious reference: run each browser's list in order, in one thread.

    With threads that end after half a millisecond without work too: a task that
    arrives as a thread gives up is still run.
    """
    priority = {0}
    pool = FairExecutor(
        workers=workers, priority=lambda key: key in priority, idle_seconds=idle
    )
    ran: dict[int, list[int]] = {}
    active: dict[int, int] = {}
    overlap = []
    lock = threading.Lock()

    def task(event, k, pause):
        with lock:
            active[event.client_id] = active.get(event.client_id, 0) + 1
            if event.client_id not in priority and active[event.client_id] > 1:
                overlap.append(event.client_id)
        time.sleep(pause / 2000)
        with lock:
            active[event.client_id] -= 1
            ran.setdefault(event.client_id, []).append(k)

    futures = [
        pool.submit(task, _event(key), k, pause) for k, (key, pause) in enumerate(tasks)
    ]
    for f in futures:
        f.result(timeout=20)
    pool.shutdown()
    expected: dict[int, list[int]] = {}
    for k, (key, _) in enumerate(tasks):
        expected.setdefault(key, []).append(k)
    assert overlap == []
    for key, ks in expected.items():
        if key in priority:  # several at once: every task once, in any order
            assert sorted(ran[key]) == ks
        else:
            assert ran[key] == ks
    assert pool.dropped == 0


def test_a_bucket_saves_a_burst_and_refills_at_its_rate():
    bucket = Bucket(rate=2.0, size=4.0, at=0.0)
    assert [bucket.take(0.0) for _ in range(5)] == [True] * 4 + [False]
    assert bucket.take(0.5) and not bucket.take(0.5)
    assert [bucket.take(100.0) for _ in range(5)] == [True] * 4 + [False]


def test_widget_values_are_what_the_widget_offers():
    server = viser.ViserServer(port=0, verbose=False)
    try:
        gui = server.gui
        drop = gui.add_dropdown("d", ("a", "b"))
        group = gui.add_button_group("g", ("Undo", "Redo"))
        slider = gui.add_slider("s", 0.0, 1.0, 0.1, 0.5)
        number = gui.add_number("n", 1.0, min=0.5, max=2.0)
        box = gui.add_checkbox("c", False)
        text = gui.add_text("t", "x")
        button = gui.add_button("b")
        upload = gui.add_upload_button("u")
        good = [
            (drop, "b"),
            (group, "Redo"),
            (slider, 1.0),
            (slider, 0),
            (number, 2.0),
            (box, True),
            (text, "y" * 200),
            (button, True),
        ]
        bad = [
            (drop, "c"),
            (drop, 1),
            (group, "Undo; rm"),
            (slider, 1.5),
            (slider, float("nan")),
            (slider, True),
            (slider, "0.5"),
            (number, 0.1),
            (number, float("inf")),
            (box, 1),
            (text, "y" * 201),
            (text, None),
            (button, False),
            (upload, "file"),
        ]
        assert all(offers(h, v) for h, v in good)
        assert not any(offers(h, v) for h, v in bad)
    finally:
        server.stop()
