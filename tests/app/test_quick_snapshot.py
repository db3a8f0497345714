"""The quick ``--snapshot`` path: the browser first, the page before the app.

``python -m app --snapshot`` launches Chromium before it imports the app, opens the page
on the app's port while the app still plans (:func:`app.media.browser.open_early`), and puts
the first picture's camera and looks in place before the page loads the scene
(:func:`app.media.pictures.open_studio`). These tests check that each shortcut gives the same
picture as the plain way, and that the light modules stay light. The speed itself is
measured by tests/benchmarks/bench_pictures.py, never asserted here.
"""

from __future__ import annotations

import io
import threading
from typing import Any

import numpy as np
from PIL import Image

from app import start_app
from app.media.browser import SLIDE_CSS, attach_page, free_port, open_early
from app.media.jobs import run_with_browser
from app.media.pictures import FirstPicture, open_studio, shoot
from tests.conftest import run_code

NAME = "02_three_obstacles"
W, H = 480, 300


def pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def same_picture(a: bytes, b: bytes) -> None:
    """Equal up to the text's anti-aliasing (the tolerance of tests/test_headless.py)."""
    diff = np.abs(pixels(a) - pixels(b)).max(axis=2)
    assert diff.shape == (H, W)
    assert diff.max() <= 2 and np.count_nonzero(diff) <= 50, (
        f"{np.count_nonzero(diff)} pixels differ, by up to {diff.max()} levels"
    )


def test_a_page_opened_before_the_app_listens_gives_the_plain_picture() -> None:
    port = free_port()
    early: dict[str, Any] = {}

    def prepare(browser: Any, started: threading.Event) -> None:
        early["page"] = open_early(
            browser, port, started, width=W, height=H, css=SLIDE_CSS
        )

    def work(planner_app: Any, browser: Any) -> tuple[bytes, bytes, bool]:
        assert planner_app.port == port
        quick = shoot(planner_app, browser, width=W, height=H, page=early["page"])
        closed = early["page"].is_closed()
        # The plain way on the same app: a new page, opened once the app is up.
        plain = shoot(planner_app, browser, width=W, height=H)
        return quick, plain, closed

    quick, plain, closed = run_with_browser(
        lambda: start_app(NAME, port=port, print_url=False), work, prepare=prepare
    )
    assert closed  # the early page is closed with its picture, as a new one is
    same_picture(quick, plain)


def test_an_early_page_that_missed_the_app_goes_to_its_address() -> None:
    # The page waits on a port where the app never comes (it takes another one): once
    # the app is up, the page is sent to the app's own address and loads it there.
    elsewhere = free_port()
    result: dict[str, Any] = {}

    def prepare(browser: Any, ready: threading.Event) -> None:
        result["page"] = open_early(browser, elsewhere, ready, width=W, height=H)

    def work(planner_app: Any, browser: Any) -> None:
        shown = attach_page(planner_app, result["page"])
        result["url"] = shown.page.url
        result["app_url"] = planner_app.url
        result["page"].context.close()

    run_with_browser(lambda: start_app(NAME, print_url=False), work, prepare=prepare)
    assert result["url"].startswith(result["app_url"].rstrip("/") + "/")


def test_a_first_picture_put_in_place_early_equals_one_changed_after_loading(
    browser: Any,
) -> None:
    # open_studio stages its `first` picture before the page loads; a picture of another
    # view is changed after loading. Both ways give the same perspective picture.
    planner_app = start_app(NAME, print_url=False)
    try:
        with open_studio(
            planner_app, browser, width=W, height=H, first=FirstPicture("perspective")
        ) as studio:
            staged = studio.picture("perspective")
    finally:
        planner_app.stop()
    planner_app = start_app(NAME, print_url=False)
    try:
        with open_studio(planner_app, browser, width=W, height=H) as studio:
            studio.picture("top")
            changed = studio.picture("perspective")
    finally:
        planner_app.stop()
    same_picture(staged, changed)


def test_the_snapshot_command_does_not_import_the_app_before_the_browser() -> None:
    # What `python -m app --snapshot` imports before it launches Chromium: no viser, no
    # planners (their import is what the browser's launch overlaps).
    code = (
        "import sys, app.__main__, app.media.jobs, app.media.slide_options\n"
        "print(sorted(m for m in ('viser', 'planners', 'app.server', 'app.ui.view')"
        " if m in sys.modules))"
    )
    assert run_code(code, timeout=60).strip() == "[]"
