"""Planner processes forked from a warm template (app.session.lanes): same answers, no leftovers."""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import resource
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

from app.session import lanes
from app.session.lanes import ProcessLane, Template, template_pid
from app.session.scheduler import default_plan
from planners import load_scene
from tests.app.app_helpers import process_running, wait_until
from tests.conftest import SCENARIOS, run_code

pytestmark = pytest.mark.skipif(
    not hasattr(lanes.os, "pidfd_open"), reason="the template needs Linux's pidfd"
)  # (the suite runs on Linux; elsewhere the workers are fresh interpreters)


def nice_of_me(value: object, memo: object = None) -> tuple[int, str]:
    """Return the worker's niceness and its first import path (run in the worker)."""
    import os

    return os.nice(0), sys.path[0]


@pytest.mark.parametrize("scenario", [SCENARIOS[0], SCENARIOS[5]], ids=lambda p: p.stem)
def test_a_forked_worker_answers_as_a_fresh_interpreter_does(monkeypatch, scenario):
    scene = load_scene(scenario)
    fn = functools.partial(default_plan, which=("dsb",))
    forked = ProcessLane(fn)
    try:
        from_fork = forked(scene)
    finally:
        forked.close()
    monkeypatch.setattr(lanes, "start_worker", lanes.spawn_worker)
    fresh = ProcessLane(fn)
    try:
        from_fresh = fresh(scene)
    finally:
        fresh.close()
    a, b = from_fork["dsb"], from_fresh["dsb"]
    assert a.status == b.status == "reached"
    assert np.array_equal(a.path, b.path)
    assert [e.kind for e in a.events] == [e.kind for e in b.events]


def test_workers_are_forks_of_one_template_and_close_ends_each():
    first, second = ProcessLane(nice_of_me), ProcessLane(nice_of_me, nice=3)
    try:
        niceness = first(None)[0]
        assert second(None)[0] == niceness + 3  # copies plan below the presenter
        template = template_pid()
        assert template is not None and process_running(template)
        pids = {first.pid, second.pid}
        assert len(pids) == 2 and template not in pids
        for pid in pids:  # the template's children, not ours
            stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            assert int(stat[1]) == template
        first.interrupt()  # a computation given up: a fresh fork, the same template
        assert first(None)[0] == niceness and first.pid not in pids
        assert template_pid() == template
    finally:
        first.close()
        second.close()
    assert not any(pid is not None and process_running(pid) for pid in pids)


@contextlib.contextmanager
def descriptors_taken_up_to(highest: int):
    """Hold every free file descriptor up to ``highest`` (a hall's open websockets)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard <= highest + 64:
        pytest.skip(f"this machine's hard limit of open files is {hard}")
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, highest + 64), hard))
    held = [os.open(os.devnull, os.O_RDONLY)]
    try:
        while held[-1] < highest:
            held.append(os.open(os.devnull, os.O_RDONLY))
        yield
    finally:
        for fd in held:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def test_workers_numbered_past_selects_limit_answer_and_end():
    # select() refuses descriptors from 1024 on; a server with 1,100 browsers connected
    # gives a new template's socket, a worker's pidfd and its pipes numbers above that.
    pids: list[int | None] = []
    with descriptors_taken_up_to(1100):
        template = Template(linger=30.0)  # its socket, in it too, is numbered > 1100
        lane = ProcessLane(nice_of_me)  # (the process's own template)
        try:
            worker = template.fork(0)
            pids.append(worker.pid)
            assert lane(None)[0] >= 0
            pids.append(lane.pid)
            assert all(pid is not None and process_running(pid) for pid in pids)
            worker.kill()
            assert worker.wait(10) == 0
        finally:
            lane.close()
            template.close()
    assert not any(pid is not None and process_running(pid) for pid in pids)


def test_the_template_leaves_when_idle_and_a_new_one_comes_when_needed():
    template = Template(linger=0.3)
    worker = template.fork(0)
    assert worker.pid is not None and process_running(worker.pid)
    first = template.pid()
    assert first is not None
    assert worker.stdin is not None
    worker.stdin.close()  # a worker ends when its stdin closes
    assert worker.wait(10) == 0
    assert wait_until(
        lambda: not process_running(first), 15
    )  # lingered 0.3 s, then left
    again = template.fork(0)  # its socket is closed: a new template forks it
    try:
        assert again.pid is not None and process_running(again.pid)
        assert template.pid() not in (None, first)
    finally:
        again.kill()
        assert again.wait(10) == 0
        template.close()


def test_a_killed_template_is_replaced_and_its_workers_go_on(monkeypatch):
    template = Template(linger=30.0)
    worker = template.fork(0)
    assert worker.pid is not None
    killed = template.pid()
    assert killed is not None
    lanes.os.kill(killed, lanes.signal.SIGKILL)
    assert wait_until(lambda: not process_running(killed), 10)
    assert process_running(worker.pid)  # a fork lives on its own
    # The next request goes to a new template, never to the dead one's socket: a
    # worker it forked an instant before its death may still hold that socket, and a
    # request sent there would get no pid.
    dead = template._sock
    asked = []
    send_fds = lanes.socket.send_fds
    monkeypatch.setattr(
        lanes.socket,
        "send_fds",
        lambda sock, *a: asked.append(sock) or send_fds(sock, *a),
    )
    after = template.fork(0)
    assert asked and dead not in asked
    assert after.pid is not None and template.pid() != killed
    for w in (worker, after):
        w.kill()
        assert w.wait(10) == 0
    template.close()


def test_a_worker_sees_import_paths_added_after_its_template_started(tmp_path):
    module = tmp_path / "late_helper.py"
    module.write_text("def twice(value, memo=None):\n    return 2 * value\n")
    lane = ProcessLane(nice_of_me)
    try:
        lane(None)  # the template runs (started before the path was added)
    finally:
        lane.close()
    sys.path.insert(0, str(tmp_path))
    try:
        late_helper = importlib.import_module("late_helper")  # the folder just added
        lane = ProcessLane(late_helper.twice)
        try:
            assert lane(21) == 42
        finally:
            lane.close()
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("late_helper", None)


def test_when_its_parent_dies_the_template_and_workers_end():
    code = textwrap.dedent(
        """
        import os, sys
        from app.session.lanes import ProcessLane, template_pid
        from tests.app.test_template import nice_of_me
        lane = ProcessLane(nice_of_me)
        lane(None)
        print(template_pid(), lane.pid, flush=True)
        os._exit(0)  # no clean-up at all
        """
    )
    pids = [int(word) for word in run_code(code, timeout=120).split()]
    assert len(pids) == 2
    assert wait_until(lambda: not any(process_running(pid) for pid in pids), 15), pids


def test_workers_asked_for_at_once_from_many_threads_each_get_their_own():
    workers = [ProcessLane(nice_of_me, start=False) for _ in range(8)]
    answers: list[object] = []
    try:
        threads = [
            threading.Thread(target=lambda w=w: answers.append(w(None)))
            for w in workers
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(60)
        assert len(answers) == len(workers)
        assert len({w.pid for w in workers}) == len(workers)
    finally:
        for w in workers:
            w.close()
