"""Two presenter pages in headless Chromium: the lecturer's laptop and the projector.

The app runs in presenter mode on 127.0.0.1 (``presenter=True``). Both pages open the
presenter's URL, as a lecturer does on the laptop and on the projector's screen. Driven
with the mouse: Explain chosen and stepped in one page shows in the other; the live robot
started in one runs in both; closing one page (and opening it again) leaves the other
working.

These tests FAIL (never skip) when Chromium cannot start. Set ``PRESENTER_SHOTS=DIR`` to
keep the screenshots of both pages (side by side: ``both.png`` while the robot drives,
``both_after.png`` once the reopened page stopped it).
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app import start_app
from app.explain.panel import METHOD_TITLES
from app.media.browser import open_page
from tests.app.app_helpers import wait_until
from tests.app.test_app_browser import CAMERA, choose, settle
from tests.app.test_app_explain_browser import browser_segments

DPR = 0.5  # a coarser canvas in the same layout: these tests read the scene, not pixels


@pytest.fixture
def planner() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False, presenter=True)
    CAMERA.apply(app.server)
    yield app
    app.stop()


def _text(page: Any) -> str:
    return page.locator("body").inner_text()


def _live_t(page: Any) -> float | None:
    """The time the page's *Live DSB* status shows (None if it shows none)."""
    found = re.search(r"Live \((?:running|stopped)\)\s*t = ([0-9.]+) s", _text(page))
    return float(found.group(1)) if found else None


def _moves_on(page: Any, timeout: float = 20.0) -> bool:
    """Whether the page's live time grows (twice) within ``timeout``."""
    first = _live_t(page) or -1.0
    if not wait_until(lambda: (_live_t(page) or -1.0) > first, timeout):
        return False
    second = _live_t(page) or -1.0
    return wait_until(lambda: (_live_t(page) or -1.0) > second, timeout)


def _open_explain(page: Any) -> None:
    page.get_by_text("Explain", exact=True).first.click()
    settle(page)


def _shots(pages: dict[str, Any], both_name: str = "both") -> None:
    """Keep each page's screenshot and all side by side (``PRESENTER_SHOTS``)."""
    folder = os.environ.get("PRESENTER_SHOTS")
    if not folder:
        return
    from PIL import Image  # only when pictures are asked for

    Path(folder).mkdir(parents=True, exist_ok=True)
    images = []
    for name, page in pages.items():
        settle(page, 5)
        path = Path(folder) / f"{name}.png"
        page.screenshot(path=str(path))
        images.append(Image.open(path))
    both = Image.new("RGB", (sum(i.width for i in images), images[0].height), "white")
    x = 0
    for image in images:
        both.paste(image, (x, 0))
        x += image.width
    both.save(Path(folder) / f"{both_name}.png")


def test_two_presenter_pages_share_explain_and_the_live_robot(browser, planner):
    room, explainer, live = planner.classroom, planner.explain.explainer, planner.live
    url = planner.presenter_url
    with open_page(planner, browser, url=url, dpr=DPR) as laptop:
        with open_page(planner, browser, url=url, dpr=DPR) as projector:
            pages = {"laptop": laptop.page, "projector": projector.page}
            for p in (laptop, projector):
                assert room.mode(p.client.client_id) == "presenter"
            assert room.counts()["presenter"] == 2
            for page in pages.values():
                assert wait_until(lambda p=page: "2 presenter browsers" in _text(p), 20)
                _open_explain(page)
            # The laptop chooses the SVG: the projector's folder and scene show it.
            choose(laptop.page, METHOD_TITLES["off"], METHOD_TITLES["svg"])
            assert wait_until(lambda: explainer.method == "svg", 20)
            assert explainer.wait_ready(30) and planner.wait_idle(30)
            assert wait_until(lambda: "step 1 of" in _text(projector.page), 20)
            shown = projector.page.locator("input[role=combobox]")
            assert any(
                shown.nth(k).input_value() == METHOD_TITLES["svg"]
                for k in range(shown.count())
            )
            hull = browser_segments(projector.page, "hull")
            assert hull is not None and len(hull) > 0
            # The projector steps forward: the laptop's folder follows.
            projector.page.get_by_role("button", name=">", exact=True).click()
            assert wait_until(lambda: explainer.step == 1, 20)
            assert wait_until(lambda: "step 2 of" in _text(laptop.page), 20)
            # The laptop starts the live robot: both pages see it drive.
            laptop.page.get_by_role("button", name="Start live").click()
            assert wait_until(lambda: live.running, 20)
            assert _moves_on(laptop.page) and _moves_on(projector.page)
            _shots(pages)
            sid = projector.client.client_id
        # The projector's page closed: the laptop's goes on (live, Explain, tools).
        assert wait_until(lambda: room.seat(sid) is None, 20)
        assert wait_until(lambda: "presenter browsers" not in _text(laptop.page), 20)
        assert _moves_on(laptop.page)
        assert explainer.method == "svg" and explainer.step == 1
        current = browser_segments(laptop.page, "current")
        assert current is not None and len(current) > 0
        # The projector's page is opened again: it shows the running robot and step 2,
        # and its buttons work.
        with open_page(planner, browser, url=url, dpr=DPR) as again:
            assert wait_until(lambda: "2 presenter browsers" in _text(again.page), 20)
            assert _moves_on(again.page)
            _open_explain(again.page)
            assert wait_until(lambda: "step 2 of" in _text(again.page), 20)
            again.page.get_by_role("button", name="Stop", exact=True).click()
            assert wait_until(lambda: not live.running, 20)
            assert wait_until(lambda: "Live (stopped)" in _text(laptop.page), 20)
            stopped = _live_t(laptop.page)
            time.sleep(1.0)
            assert _live_t(laptop.page) == stopped
            assert stopped is not None and np.isfinite(stopped)
            assert wait_until(lambda: _live_t(again.page) == stopped, 20)
            _shots({"laptop_after": laptop.page, "again": again.page}, "both_after")
