"""The app's Live DSB mode in headless Chromium and without a browser."""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import shapely
from numpy.testing import assert_allclose
from shapely import Polygon

from app import start_app
from app.live import LivePanel
from app.session.controller import TOOLS
from planners.scene import Robot, Scene, load_scene
from tests.app.app_helpers import TopCamera, wait_until
from tests.app.test_app_browser import choose, click

WIDTH, HEIGHT = 1280, 800
DPR = 0.5  # a coarser canvas in the same layout: the test reads the scene, not pixels
CAMERA = TopCamera(
    look_at=(7.0, 4.0), height=14.0, fov_deg=50.0, width=WIDTH, px_height=HEIGHT
)
FAST = 4.0  # simulated seconds per wall second of the browser test's robot
SHOTS = os.environ.get("LIVE_SHOTS")  # a folder: save screenshots to look at


def _hall() -> Scene:
    return Scene(
        obstacles=(Polygon([(8.5, 7.0), (9.5, 7.0), (9.5, 7.6), (8.5, 7.6)]),),
        start=(1.0, 4.0),
        goal=(9.0, 4.0),
        boundary=Polygon([(0, 0), (10, 0), (10, 8), (0, 8)]),
        robot=Robot(radius=0.3),
        sensor_range=2.0,
        name="hall",
    )


@pytest.fixture
def hall() -> Iterator[Any]:
    app = start_app(_hall(), port=0, print_url=False)
    CAMERA.apply(app.server)
    yield app
    app.stop()


def _open(browser: Any, app: Any) -> Any:
    page = browser.new_page(
        viewport={"width": WIDTH, "height": HEIGHT}, device_scale_factor=1
    )
    page.goto(f"{app.url}?fixedDpr={DPR}")
    page.wait_for_function(
        "() => window.__viserMutable && ('/live/trail' in window.__viserMutable.nodeRefFromName)",
        timeout=60_000,
    )
    time.sleep(1.0)
    return page


def test_live_robot_turns_away_from_a_new_obstacle_before_touching_it(browser, hall):
    page = _open(browser, hall)
    live = hall.live
    live.speed = FAST  # the same steps and decisions (the test below), sooner
    page.get_by_role("button", name="Start live").click()
    assert wait_until(lambda: live.state is not None and live.state.t > 1.0, 30)
    # The lecturer pauses the robot, drops a block on its way 3 m ahead of it (beyond
    # R = 2 m) and lets it go on. Paused, because a click on a loaded machine takes
    # seconds of driving: the block could land on the robot.
    live.stop()
    assert wait_until(lambda: not live.running, 20)
    choose(page, TOOLS["drag"], TOOLS["block"])
    assert wait_until(lambda: hall.controller.frame.tool == "block")
    state = live.state
    assert state is not None
    click(page, (min(state.pose[0] + 3.0, 6.5), 4.0))
    assert wait_until(lambda: len(hall.controller.scene.obstacles) == 2, 20)
    block = hall.controller.scene.obstacles[-1]
    assert live.state is not None and live.state.t == state.t  # it waited there
    added_at = state.t
    live.start()
    if SHOTS:
        page.screenshot(path=os.path.join(SHOTS, "live_1_block.png"))
    # (Mid-way for the picture: a loaded machine may already have reached the goal.)
    assert wait_until(
        lambda: (
            live.state is not None
            and (live.state.t > added_at + 6 or live.state.status == "reached")
        ),
        120,
    )
    if SHOTS:
        page.screenshot(path=os.path.join(SHOTS, "live_2_around.png"))
    assert wait_until(
        lambda: (
            live.state is not None and live.state.status in ("reached", "unreachable")
        ),
        180,
    ), (live.state, block.bounds)
    assert live.state.status == "reached", (live.state.pose, block.bounds)
    if SHOTS:
        page.screenshot(path=os.path.join(SHOTS, "live_3_reached.png"))
    page.get_by_role("button", name="Stop").click()
    trace = live.trace()
    assert trace is not None and trace.status == "reached"
    path = trace.path
    # It changed course: it left the straight line y = 4 on the block's account...
    assert np.abs(path[:, 1] - 4.0).max() > 0.5
    # ... before touching it: never within the robot's radius of the block.
    keep = block.buffer(0.3 * np.cos(np.pi / 16) - 1e-6)
    assert not any(keep.contains(shapely.Point(p)) for p in path)
    # The turn came from what it sensed: the first hit event is after the block came.
    hits = [e for e in trace.events if e.kind == "hit"]
    assert hits and hits[0].t >= added_at - 0.5
    # The record is JSON.
    assert json.loads(trace.to_json())["status"] == "reached"
    page.close()


def test_live_runs_a_moving_scenario_without_a_browser():
    scene = load_scene("static_scenarios/10_person_crossing.json")
    limited = dataclasses.replace(
        scene.robot, max_wheel_rate=12.0, max_wheel_acceleration=40.0
    )
    scene = dataclasses.replace(scene, robot=limited)
    app = start_app(scene, port=0, print_url=False)
    try:
        live = app.live
        assert live is not None
        live.start()
        # Edits go on while it drives: move the goal a little, twice.
        app.controller.edits.move_goal((9.0, 4.0))
        assert wait_until(lambda: live.state is not None and live.state.t > 2.0, 30)
        app.controller.edits.move_goal((9.0, 4.5))
        assert app.wait_idle(20)
        live.stop()
        state = live.state
        assert state is not None and not live.running
        t = state.t
        time.sleep(0.3)
        assert live.state is state and state.t == t  # stopped means stopped
        trace = live.trace()
        assert trace is not None and len(trace.steps) >= 40
        assert trace.steps[-1].offsets  # the person's offset is recorded
        # The wheel rates stay within the limit, and the live plot draws it.
        assert np.abs(trace.rates).max() <= 12.0 * (1 + 1e-9)
        panel = live.on_change
        assert isinstance(panel, LivePanel)
        panel(live.state, live.running)
        labels = [s["label"] for s in panel.plot.series]
        assert labels[-2:] == ["+limit", "-limit"]
        assert_allclose(panel.plot.data[-2], 12.0)
        # The replay slider's answer: the robot and the person where they were at t.
        k = len(trace.steps) // 2
        live.show_at(trace.steps[k].t)
        assert_allclose(app.view.robot.position[:2], trace.steps[k].pose[:2])
        person = np.asarray(live._moving.points)[:, :, :2].reshape(-1, 2)
        recorded = np.asarray(trace.steps[k].obstacles[1].exterior.coords)
        assert_allclose(person.min(axis=0), recorded.min(axis=0))
        live.reset()
        assert live.state is None
    finally:
        app.stop()


def test_the_robot_takes_the_same_steps_and_decisions_at_any_speed():
    app = start_app(_hall(), port=0, print_url=False)
    try:
        live = app.live
        assert live is not None
        traces = []
        for speed in (8.0, 32.0):
            live.reset()
            live.speed = speed
            live.start()
            assert wait_until(lambda: live.state is not None and not live.running, 60)
            trace = live.trace()
            assert trace is not None and trace.status == "reached"
            traces.append(trace)
        slow, fast = traces
        assert len(slow.steps) == len(fast.steps) > 40
        assert np.array_equal(slow.path, fast.path)
        assert [s.t for s in slow.steps] == [s.t for s in fast.steps]
        assert slow.events == fast.events
        with pytest.raises(ValueError, match="positive"):
            live.speed = 0.0
        assert live.speed == 32.0
    finally:
        app.stop()
