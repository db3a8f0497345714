"""The self-contained page (app.export_html): opens from disk, offline, and plays the run.

The page is opened as a ``file://`` URL in headless Chromium with every request other than
``file:``, ``data:`` and ``blob:`` refused, and no app server running.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app import start_app
from app.export_html import export_html, export_page
from tests.browser import use_browser

ROOT = Path(__file__).resolve().parents[2]
NAME = "02_three_obstacles"
LOCAL = ("file:", "data:", "blob:")

ROBOT_JS = """() => {
    const o = window.__viserMutable.nodeRefFromName['/robot'];
    return o ? [o.position.x, o.position.y] : null;
}"""


@pytest.fixture(scope="module")
def browser() -> Iterator:
    with use_browser() as shared:
        yield shared


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


def test_opened_from_disk_offline_it_shows_the_scene_and_the_robot_moves(
    browser, page_file, tmp_path
) -> None:
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
        first = page.evaluate(ROBOT_JS)
        shot_a = tmp_path / "a.png"
        page.screenshot(path=shot_a)
        time.sleep(2.0)
        second = page.evaluate(ROBOT_JS)
        shot_b = tmp_path / "b.png"
        page.screenshot(path=shot_b)
    finally:
        context.close()
    assert first is not None and second is not None
    assert np.hypot(second[0] - first[0], second[1] - first[1]) > 0.3  # [m]
    a = np.asarray(Image.open(shot_a).convert("RGB"), dtype=int)
    b = np.asarray(Image.open(shot_b).convert("RGB"), dtype=int)
    assert (np.abs(a - b).max(axis=2) > 32).mean() > 1e-4  # the picture moved too
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
