"""The second lane (slow planners such as DSB) and the DSB drawing.

The lane is tested with a fake slow planner whose speed the test controls; the drawing of a
real TangentBug run is tested when :mod:`planners.bug.tangent_bug` is present.
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import threading
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

import planners
from app.session import robot
from app.session.controller import Controller, Pending, default_plan
from app.session.scheduler import SLOW_NICE
from app.ui.panels import results_markdown
from tests.app.app_helpers import SCENARIO_DIR, FakeView, process_running, wait_until


@dataclasses.dataclass(frozen=True)
class FakeTrace:
    goal: tuple[float, float]
    path: np.ndarray
    status: str = "reached"
    reason: str | None = None
    length: float | None = 1.0
    ms: float = 0.0


def gated_slow_plan(gate: threading.Event, calls: list[tuple[float, float]]):
    def slow(scene: planners.Scene) -> dict[str, Any]:
        calls.append(scene.goal)
        gate.wait(10)
        return {"dsb": FakeTrace(scene.goal, np.array([scene.start, scene.goal]))}

    return slow


@pytest.fixture
def scene() -> planners.Scene:
    return planners.load_scene(SCENARIO_DIR / "01_two_convex.json")


def make(scene, **kwargs) -> tuple[Controller, FakeView]:
    view = FakeView()
    controller = Controller(
        view,
        scene,
        plan=lambda s: default_plan(s, ("vg", "svg")),
        slow_names=("dsb",),
        **kwargs,
    )
    return controller, view


def _assert_settles_on(controller, view, goal):
    """Once the slow planner is released: its result for ``goal`` is shown, not lagging."""
    assert controller.wait_idle(10)
    final = view.last.plans["dsb"]
    assert isinstance(final, FakeTrace) and final.goal == goal
    assert not view.last.lagging


def test_fast_planners_are_drawn_while_the_slow_one_computes(scene):
    gate, calls = threading.Event(), []
    controller, view = make(scene, slow_plan=gated_slow_plan(gate, calls))
    try:
        assert not controller.wait_idle(0.5)  # the slow lane is still busy
        frame = view.last
        assert frame.plans["vg"].status == "ok"
        assert isinstance(frame.plans["dsb"], Pending)
        assert len(frame.plans["dsb"].path) == 0  # no path until it is ready
        gate.set()
        assert controller.wait_idle(10)
        assert view.last.plans["dsb"].goal == scene.goal
        assert view.last.plans["dsb"].status == "reached"
    finally:
        gate.set()
        controller.close()


def test_a_stale_slow_result_never_replaces_a_newer_one(scene):
    gate, calls = threading.Event(), []
    controller, view = make(scene, slow_plan=gated_slow_plan(gate, calls))
    try:
        goals = [scene.goal] + [(9.0, 6.0 - 0.5 * k) for k in range(5)]
        for goal in goals[1:]:
            controller.edits.move_goal(goal)
        gate.set()
        assert controller.wait_idle(10)
        shown = []
        for frame in view.frames:
            dsb = frame.plans["dsb"]
            if isinstance(dsb, Pending):
                continue
            if "dsb" in frame.lagging:
                # An older scene's result, shown while the newest computes.
                assert dsb.goal != frame.scene.goal
            else:
                assert dsb.goal == frame.scene.goal
            shown.append(goals.index(dsb.goal))
        assert shown == sorted(shown)  # never an older result after a newer one
        assert view.last.plans["dsb"].goal == goals[-1] and not view.last.lagging
        # The slow lane skipped the versions that were outdated before it got to them.
        assert len(calls) < len(goals)
    finally:
        gate.set()
        controller.close()


def test_a_lagging_slow_result_is_shown_during_a_drag_but_not_after_a_bad_edit(scene):
    release = threading.Event()
    calls: list[tuple[float, float]] = []

    def slow(s):
        calls.append(s.goal)
        if len(calls) > 1:
            release.wait(10)
        return {"dsb": FakeTrace(s.goal, np.array([s.start, s.goal]))}

    controller, view = make(scene, slow_plan=slow)
    try:
        assert controller.wait_idle(10)  # the first scene's result is in
        controller.edits.move_goal((9.0, 6.0))
        assert wait_until(lambda: view.last.version == controller.version)
        frame = view.last
        assert "dsb" in frame.lagging and frame.plans["dsb"].goal == scene.goal
        assert "updating" in results_markdown(frame.plans, frame.lagging)
        # The goal dragged into an obstacle: no DSB path at all, not the old one, and
        # the reason at once (it is the same for every planner).
        controller.edits.move_goal((3.0, 3.0))
        assert wait_until(lambda: view.last.version == controller.version)
        dsb = view.last.plans["dsb"]
        assert dsb.status == "invalid" and len(dsb.path) == 0 and not view.last.lagging
        assert dsb.reason == view.last.plans["vg"].reason
        assert "inside obstacle" in dsb.reason
        release.set()
        _assert_settles_on(controller, view, (3.0, 3.0))
    finally:
        release.set()
        controller.close()


def test_a_lagging_result_must_tell_the_same_story_as_the_fast_planners():
    """Dragging an enclosed goal: the last "unreachable" walk stands in, a "reached" never."""
    scene = planners.load_scene(SCENARIO_DIR / "07_goal_enclosed.json")
    release = threading.Event()
    calls: list[tuple[float, float]] = []
    inside = (6.5, 4.0)  # enclosed: VG says unreachable

    def slow(s):
        calls.append(s.goal)
        if len(calls) > 1:
            release.wait(10)
        status = (
            "unreachable" if s.goal[0] > 5.5 and 3.5 < s.goal[1] < 4.5 else "reached"
        )
        return {"dsb": FakeTrace(s.goal, np.array([s.start, s.goal]), status)}

    controller, view = make(scene, slow_plan=slow)
    try:
        assert controller.wait_idle(10)
        assert view.last.plans["dsb"].status == "unreachable"
        # Within the enclosure: the old "unreachable" walk is shown, marked as updating.
        controller.edits.move_goal((inside[0] + 0.2, inside[1]))
        assert wait_until(lambda: view.last.version == controller.version)
        assert view.last.plans["vg"].status == "unreachable"
        assert "dsb" in view.last.lagging
        assert view.last.plans["dsb"].status == "unreachable"
        # Out of the enclosure: VG finds a path, so the old walk would contradict it.
        controller.edits.move_goal((2.0, 7.0))
        assert wait_until(lambda: view.last.version == controller.version)
        assert view.last.plans["vg"].status == "ok"
        assert isinstance(view.last.plans["dsb"], Pending) and not view.last.lagging
        release.set()
        _assert_settles_on(controller, view, (2.0, 7.0))
    finally:
        release.set()
        controller.close()


def test_a_failing_slow_planner_shows_an_error_not_a_path(scene):
    def broken(s):
        raise RuntimeError("sensor exploded")

    controller, view = make(scene, slow_plan=broken)
    try:
        assert controller.wait_idle(10)
        dsb = view.last.plans["dsb"]
        assert dsb.status == "error" and len(dsb.path) == 0
        assert any("sensor exploded" in p for p in view.last.problems)
        assert view.last.plans["vg"].status == "ok"
    finally:
        controller.close()


# ----------------------------------------------------------------------------- real DSB


@pytest.fixture
def with_dsb():
    """The real TangentBug, registered as "dsb" in :data:`planners.REGISTRY`."""
    tangent_bug = pytest.importorskip("planners.bug.tangent_bug")
    assert planners.REGISTRY["dsb"].kind == "trace"
    return tangent_bug


def test_real_dsb_run_is_drawn_by_mode_with_its_events(with_dsb, server_view):
    view, make_controller = server_view
    scene = planners.load_scene(SCENARIO_DIR / "06_four_obstacles_sensor.json")
    controller = make_controller(scene)
    trace = controller.frame.plans["dsb"]
    assert trace.status == "reached"
    segments = np.asarray(view.traces["dsb"].path.handle.points)
    assert len(segments) == len(trace.path) - 1
    colors = np.asarray(view.traces["dsb"].path.handle.colors)
    from app.ui.style import COLORS
    from app.ui.view import vertex_colors

    for mode, color in zip(trace.modes, colors[:, 0], strict=True):
        want = vertex_colors(COLORS["dsb_seek" if mode == "seek" else "dsb_follow"])
        assert tuple(color) == tuple(want)
    shown = " ".join(
        h.text for h in view.traces["dsb"].labels.handles if h.visible
    ).split()
    assert shown == [e.label for e in trace.events]


def test_following_dsb_shows_what_the_robot_senses(with_dsb, server_view):
    view, make_controller = server_view
    scene = planners.load_scene(SCENARIO_DIR / "06_four_obstacles_sensor.json")
    controller = make_controller(scene)
    controller.playback.set_follow("dsb")
    assert controller.wait_idle(30)
    trajectory = controller.frame.trajectory
    assert trajectory is not None
    # A moment of the run when the robot sees some O_i (the tangent graph is drawn).
    for fraction in (1 / 3, 0.25, 0.4, 0.15, 0.5, 0.1, 0.6):
        controller.playback.set_robot_time(trajectory.duration * fraction)
        assert controller.wait_idle(10)
        if view.sensing_graph.handle.visible:
            break
    else:
        pytest.fail("the local tangent graph was never shown along the DSB run")
    assert view.sensing_circle.handle.visible
    circle = np.asarray(view.sensing_circle.handle.points)[:, 0, :2]
    center = circle.mean(axis=0)
    radius = float(np.hypot(*(circle - center).T).mean())
    assert radius == pytest.approx(scene.sensor_range, rel=1e-3)
    assert math.dist(center, view.robot.position[:2]) < 0.3  # around the robot
    # The tangent lines start at the robot's sensing position.
    tangents = np.asarray(view.sensing_graph.handle.points)
    assert_allclose(
        tangents[:-1, 0, :2],
        np.broadcast_to(center, tangents[:-1, 0, :2].shape),
        atol=0.05,
    )
    # Following VG: no sensing.
    controller.playback.set_follow("vg")
    assert controller.wait_idle(10)
    assert not view.sensing_circle.handle.visible


@pytest.fixture
def server_view():
    import viser

    from app.ui.view import PlannerView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    view = PlannerView(server)
    view.robot_model_fn = robot.robot_model
    made: list[Controller] = []

    def make_controller(scene):
        controller = Controller(
            view, scene, trajectory=robot.trajectory, sample=robot.sample
        )
        made.append(controller)
        assert controller.wait_idle(60)
        return controller

    yield view, make_controller
    for controller in made:
        controller.close()
    server.stop()


def test_slow_planners_run_in_a_worker_process_that_close_stops(with_dsb, scene):
    view = FakeView()
    controller = Controller(view, scene)
    try:
        lane = controller.scheduler.process
        assert lane is not None and lane.pid is not None and lane.pid != os.getpid()
        assert controller.wait_idle(60)
        # Below the server's priority: on a busy machine the VG/SVG round goes first.
        assert SLOW_NICE > 0
        niceness = os.getpriority(os.PRIO_PROCESS, lane.pid)
        assert niceness == min(19, os.nice(0) + SLOW_NICE)
        dsb = view.last.plans["dsb"]
        assert dsb.status == "reached"
        assert_allclose(dsb.path[-1], scene.goal)
        # The result came back with what the robot needs to show what it senses.
        assert len(dsb.sensing_at(0.5).segments) >= 0
        pid = lane.pid
    finally:
        controller.close()
    assert not process_running(pid)


def test_a_dead_worker_process_is_restarted(with_dsb, scene):
    view = FakeView()
    controller = Controller(view, scene)
    try:
        assert controller.wait_idle(60)
        lane = controller.scheduler.process
        assert lane is not None
        assert lane.pid is not None
        os.kill(lane.pid, signal.SIGKILL)
        controller.edits.move_goal((9.0, 1.0))
        assert controller.wait_idle(60)
        assert view.last.plans["dsb"].status == "reached"
        assert_allclose(view.last.plans["dsb"].path[-1], (9.0, 1.0))
    finally:
        controller.close()
