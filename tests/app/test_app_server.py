"""Starting and stopping the app, finding scenarios, the command line, the panel's wiring."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from typing import Any

import pytest

import planners
from app import start_app
from app.server import list_scenarios, resolve_scenario
from planners.scene import ScenarioError
from tests.app.app_helpers import ROOT, SCENARIO_DIR
from tests.conftest import run_module


def port_is_open(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_start_and_stop_on_a_free_port():
    app = start_app(port=0, print_url=False)
    try:
        port = app.port
        assert isinstance(port, int) and port > 0
        assert app.url == f"http://127.0.0.1:{port}/"
        with urllib.request.urlopen(app.url, timeout=10) as response:
            assert response.status == 200
            assert b"<html" in response.read(2000).lower()
        frame = app.controller.frame
        assert frame is not None and frame.scenario == "01_two_convex"
        assert frame.plans["vg"].status == "ok"
        assert app.wait_idle(5)
    finally:
        app.stop()
    deadline = time.monotonic() + 5
    while port_is_open(port) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not port_is_open(port)
    assert not app.controller.scheduler.alive


def test_start_with_a_scene_and_set_robot_time(capsys):
    scene = planners.load_scene(SCENARIO_DIR / "08_narrow_gap.json")
    app = start_app(scene, port=0, print_url=True)
    try:
        assert app.url in capsys.readouterr().out
        app.set_robot_time(1.5)
        assert app.wait_idle(10)
        t, playing, _ = app.controller.playback.state
        assert t == 1.5 and not playing
        assert app.controller.scene == scene
    finally:
        app.stop()


@pytest.mark.parametrize(
    ("name", "key"),
    [
        ("01_two_convex", "01_two_convex"),
        ("two_convex", "01_two_convex"),
        ("Two-Convex", "01_two_convex"),
        ("06", "06_four_obstacles_sensor"),
        ("narrow", "08_narrow_gap"),
        (str(SCENARIO_DIR / "07_goal_enclosed.json"), "07_goal_enclosed"),
    ],
)
def test_resolve_scenario(name, key):
    found, path = resolve_scenario(name)
    assert found == key
    assert path == list_scenarios()[key] or path.resolve() == list_scenarios()[key]


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("nope", "no such scenario"),
        ("convex", "ambiguous"),
        ("missing.json", "no such file"),
    ],
)
def test_resolve_scenario_errors_say_what_to_do(name, words):
    with pytest.raises(ScenarioError, match=words):
        resolve_scenario(name)


def run_cli(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return run_module("app", *args, timeout=timeout)


@pytest.mark.parametrize(
    "args", [("--scenario", "nope"), ("--scenario", "/tmp/definitely/missing.json")]
)
def test_cli_bad_scenario_is_one_line_and_exit_2(args):
    result = run_cli(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert lines[0].startswith("error: ")


def test_cli_invalid_scenario_file_is_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": 1, "obstacles": [], "start": [0, 0]}')
    result = run_cli("--scenario", str(bad))
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "goal" in result.stderr


def test_cli_serves_and_prints_the_url():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "--scenario", "two_convex", "--port", str(port)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        assert f"http://127.0.0.1:{port}/" in line
        with urllib.request.urlopen(
            f"http://127.0.0.1:{port}/", timeout=10
        ) as response:
            assert response.status == 200
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def fire(handle: Any, value: Any = None) -> None:
    """Act like a user in a browser: set the value and run the callbacks with a client."""
    from viser._gui_handles import GuiEvent

    if value is not None:
        handle._impl.value = value
    for cb in list(handle._impl.update_cb):
        cb(GuiEvent(client=object(), client_id=1, target=handle))  # type: ignore[arg-type]


def test_panel_controls_call_the_controller():
    app = start_app("04_convex_nonconvex_b", port=0, print_url=False)
    try:
        panels, controller = app.panels, app.controller
        assert panels is not None  # loopback: one panel for everyone
        fire(panels.expansion, "square")
        fire(panels.radius, 0.2)
        fire(panels.kind, "differential")
        fire(panels.sensor_range, 4.0)
        fire(panels.layers["vg_edges"], False)
        assert app.wait_idle(20)
        s = controller.scene
        assert (s.expansion, s.robot.radius, s.robot.kind, s.sensor_range) == (
            "square",
            0.2,
            "differential",
            4.0,
        )
        frame = controller.frame
        assert frame is not None and frame.layers["vg_edges"] is False
        fire(panels.history, "Undo")
        assert app.wait_idle(20)
        assert controller.scene.sensor_range == pytest.approx(
            planners.load_scene(
                SCENARIO_DIR / "04_convex_nonconvex_b.json"
            ).sensor_range
        )
        # The panel shows the scene after the undo, and values it sets itself are not edits.
        assert panels.sensor_range.value == pytest.approx(controller.scene.sensor_range)
        version = controller.version
        panels.radius.value = 0.5  # programmatic: no client, not a user edit
        assert app.wait_idle(10) and controller.version == version
        fire(panels.scenario, "06_four_obstacles_sensor")
        assert app.wait_idle(20)
        assert len(controller.scene.obstacles) == 4
        assert "Four obstacles" in panels.title.content
    finally:
        app.stop()


def test_the_scenario_dropdown_names_an_own_scene_as_such():
    """A scene that is no shipped scenario (here given to start_app, as an upload or a
    folder file is) shows as "(your own scene)", never as the last scenario chosen;
    choosing that entry changes nothing, and a shipped one loads again."""
    from app.ui.panels import OWN_SCENE

    scene = planners.load_scene(SCENARIO_DIR / "08_narrow_gap.json")
    app = start_app(scene, port=0, print_url=False)
    try:
        controller, panels = app.controller, app.panels
        assert panels is not None and app.wait_idle(20)
        assert panels.scenario.value == OWN_SCENE
        assert OWN_SCENE in panels.scenario.options
        version = controller.version
        fire(panels.scenario, OWN_SCENE)
        assert app.wait_idle(10) and controller.version == version
        fire(panels.scenario, "01_two_convex")
        assert app.wait_idle(20)
        assert panels.scenario.value == "01_two_convex"
        version = controller.version
        fire(panels.scenario, OWN_SCENE)  # while a shipped one shows: back to its name
        assert app.wait_idle(10) and controller.version == version
        assert panels.scenario.value == "01_two_convex"
        # An upload after a shipped scenario: the dropdown no longer names that one.
        controller.files.load_text((SCENARIO_DIR / "08_narrow_gap.json").read_bytes())
        assert app.wait_idle(20)
        assert "diagonal gap" in panels.title.content.lower()
        assert panels.scenario.value == OWN_SCENE
    finally:
        app.stop()
