"""The self-contained page (app.media.export_html): opens from disk, offline, and plays the run.

The page is opened as a ``file://`` URL in headless Chromium with every request other than
``file:``, ``data:`` and ``blob:`` refused, and no app server running.
"""

from __future__ import annotations

import contextlib
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from app import start_app
from app.media.export_html import export_html, export_page
from app.media.jobs import JobFailure
from app.media.record_live import live_trace
from app.server import resolve_scenario
from app.ui.style import HEIGHTS
from app.ui.view import prism_mesh
from planners.scene import load_scene, scene_at
from tests.app.app_helpers import live_drawings

ROOT = Path(__file__).resolve().parents[2]
NAME = "02_three_obstacles"
PERSON = "10_person_crossing"  # obstacle 2 walks across the robot's way
LOCAL = ("file:", "data:", "blob:")

ROBOT_JS = """() => {
    const o = window.__viserMutable.nodeRefFromName['/robot'];
    return o ? [o.position.x, o.position.y] : null;
}"""


@pytest.fixture(scope="module")
def page_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("page") / "run.html"
    assert export_html(NAME, out, fps=10) == 0
    return out


def test_the_page_has_everything_inline(page_file) -> None:
    text = page_file.read_text(encoding="utf-8")
    assert "window.__VISER_EMBED_DATA__=" in text
    assert 'id="planner-legend"' in text and "Three obstacles" in text
    # Nothing to fetch: no script, stylesheet or image source outside the file.
    for attr in re.findall(r'(?:src|href)="([^"]*)"', text):
        assert attr.startswith(("data:", "#")) or attr == "", attr


@contextlib.contextmanager
def _offline(browser, page_file: Path) -> Iterator[tuple[Any, list[str]]]:
    """Open ``page_file`` from disk with the network refused; yield the page and the
    URLs it asked for, once the robot's node is there."""
    context = browser.new_context(
        viewport={"width": 800, "height": 500}, device_scale_factor=1
    )
    asked: list[str] = []

    def refuse_network(route) -> None:
        asked.append(route.request.url)
        if route.request.url.startswith(LOCAL):
            route.continue_()
        else:
            route.abort()

    context.route("**/*", refuse_network)
    try:
        page = context.new_page()
        page.goto(page_file.as_uri())
        page.wait_for_function(
            "() => { const m = window.__viserMutable;"
            " return m && m.nodeRefFromName && m.nodeRefFromName['/robot']; }",
            timeout=60_000,
        )
        yield page, asked
    finally:
        context.close()


def _two_moments(page: Any, tmp_path: Path) -> tuple[Any, Any, np.ndarray, np.ndarray]:
    """The robot's position and a picture, then both again 2 s later."""
    pictures, robots = [], []
    for k in range(2):
        if k:
            time.sleep(2.0)
        robots.append(page.evaluate(ROBOT_JS))
        shot = tmp_path / f"moment{k}.png"
        page.screenshot(path=shot)
        pictures.append(np.asarray(Image.open(shot).convert("RGB"), dtype=int))
    return robots[0], robots[1], pictures[0], pictures[1]


def test_opened_from_disk_offline_it_shows_the_scene_and_the_robot_moves(
    browser, page_file, tmp_path
) -> None:
    with _offline(browser, page_file) as (page, asked):
        names = set(
            page.evaluate("() => Object.keys(window.__viserMutable.nodeRefFromName)")
        )
        for node in (
            "/obstacles/body/0",
            "/expanded/fill/0",
            "/vg/path",
            "/vg/edges",
            "/svg/path",
            "/dsb/path",
            "/dsb/labels/0",
            "/obstacles/labels/0",
            "/handles/start/marker",
            "/handles/goal/marker",
            "/robot/body0",
            "/robot/wheel0/spin",
        ):
            assert node in names, node
        first, second, a, b = _two_moments(page, tmp_path)
    assert first is not None and second is not None
    assert np.hypot(second[0] - first[0], second[1] - first[1]) > 0.3  # [m]
    assert (np.abs(a - b).max(axis=2) > 32).mean() > 1e-4  # the picture moved too
    assert asked and all(url.startswith(LOCAL) for url in asked), asked


# --------------------------------------------------------------------------- moving obstacles


def test_a_moving_scenarios_page_plays_its_live_run(monkeypatch) -> None:
    """Frame k of the page is the live run at k / fps, as a recording draws it: every
    obstacle where it is then, the robot at the trace's pose; the legend is the run's.
    The app's own drawing comes back only once the page is made, so it is not the
    page's last frame. ``--follow`` is refused for it in one line (exit code 2)."""
    planner_app = start_app(PERSON, print_url=False)
    order: list[str] = []
    make_serializer = planner_app.server.get_scene_serializer
    render = planner_app.view.render

    def serializer() -> Any:
        order.append("recording")
        made = make_serializer()
        as_html = made.as_html
        monkeypatch.setattr(made, "as_html", lambda: order.append("page") or as_html())
        return made

    monkeypatch.setattr(planner_app.server, "get_scene_serializer", serializer)
    monkeypatch.setattr(
        planner_app.view, "render", lambda f: order.append("render") or render(f)
    )
    try:
        with live_drawings(planner_app.view) as drawn:
            page = export_page(planner_app, fps=2, until=3.0)
        recorded = order[order.index("recording") + 1 :]
        assert recorded[:8] == ["render"] * 7 + ["page"]
        assert recorded[8:] and set(recorded[8:]) == {"render"}  # the app's own again
        assert planner_app.wait_idle(30)
        start = planner_app.controller.scene.start
        np.testing.assert_allclose(planner_app.view.robot.position[:2], start)
        with pytest.raises(JobFailure, match="--follow vg: this scenario's obstacles"):
            export_page(planner_app, follow="vg")
    finally:
        planner_app.stop()
    scene = load_scene(resolve_scenario(PERSON)[1])
    trace = live_trace(scene, until=3.0)
    assert len(drawn) == 7  # t = 0, 0.5, ..., 3
    for k, (vertices, xy) in enumerate(drawn):
        t = k / 2
        assert xy == tuple(trace.poses[round(t / trace.dt)][:2])
        expected, _ = prism_mesh(scene_at(scene, t).obstacles, HEIGHTS["obstacle"])
        np.testing.assert_allclose(vertices, expected, atol=1e-6)
    assert "moving obstacle" in page and "DSB to goal" in page
    assert "VG graph" not in page  # the live run's legend, not the app's


def test_a_moving_scenarios_page_opened_offline_moves_the_person(
    browser, tmp_path
) -> None:
    out = tmp_path / "person.html"
    assert export_html(PERSON, out, fps=10) == 0
    with _offline(browser, out) as (page, asked):
        first, second, a, b = _two_moments(page, tmp_path)
    assert first is not None and second is not None
    assert np.hypot(second[0] - first[0], second[1] - first[1]) > 0.3  # [m]
    assert (np.abs(a - b).max(axis=2) > 32).mean() > 1e-4
    assert asked and all(url.startswith(LOCAL) for url in asked), asked


def test_the_recording_holds_a_frame_per_step_of_the_run() -> None:
    planner_app = start_app(NAME, print_url=False)
    try:
        short = export_page(planner_app, fps=4, until=1.0)
        longer = export_page(planner_app, fps=4, until=3.0)
    finally:
        planner_app.stop()
    # More of the run, more robot poses: the page grows with the recording.
    assert len(longer) > len(short)


def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys) -> None:
    for kwargs, message in [
        ({"out": tmp_path / "x.txt"}, "must end in .html"),
        ({"out": tmp_path / "x.html", "fps": 500.0}, "fps must be from 1 to 60"),
        ({"out": tmp_path / "x.html", "follow": "rrt"}, "unknown planner 'rrt'"),
        ({"out": tmp_path / "x.html", "until": -1.0}, "end time must be a finite"),
        ({"out": tmp_path / "x.html", "until": float("nan")}, "end time must be"),
    ]:
        assert export_html(NAME, **kwargs) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and err.count("\n") == 1
    assert export_html(tmp_path / "missing.json", tmp_path / "y.html") == 2
    assert "cannot load scenario" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_the_command_line_writes_the_page(tmp_path) -> None:
    out = tmp_path / "course" / "run.html"
    result = subprocess.run(
        [sys.executable, "-m", "app", "--scenario", "01", "--export-html", str(out),
         "--fps", "5", "--follow", "svg"],
        capture_output=True, text=True, cwd=ROOT, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""
    assert out.stat().st_size > 800_000  # viser's client alone is about 0.8 MB
