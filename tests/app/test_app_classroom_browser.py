"""End to end in headless Chromium: a presenter and a watcher, then the watcher's own copy.

The app runs in presenter mode on 127.0.0.1 (``presenter=True``, what ``--host 0.0.0.0``
turns on by itself). Two pages: the presenter's URL (its secret in the websocket path) and
the plain URL a student opens. Driven with the mouse, as people would.

These tests FAIL (never skip) when Chromium cannot start. Set ``CLASSROOM_SHOTS=DIR`` to
keep the screenshots of the three screens (presenter, watcher, private copy).
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app import start_app
from app.media.browser import open_page
from tests.app.app_helpers import TopCamera, mouse_drag, settle, wait_until

WIDTH, HEIGHT = 1280, 800
DPR = 0.5  # a coarser canvas in the same layout: the test reads the scene, not pixels
CAMERA = TopCamera(
    look_at=(7.0, 4.0), height=14.0, fov_deg=50.0, width=WIDTH, px_height=HEIGHT
)
PLANE_OFFSET = 0.24 * 0.9  # the XY-plane square of a start/goal gizmo (scale 0.9) [m]


@pytest.fixture
def planner() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False, presenter=True)
    CAMERA.apply(app.server)
    yield app
    app.stop()


def _drag(page: Any, start_xy: Any, end_xy: Any) -> None:
    """Drag with the mouse from the gizmo at ``start_xy`` to ``end_xy`` (floor metres)."""
    start = CAMERA.pixel((start_xy[0] + PLANE_OFFSET, start_xy[1] + PLANE_OFFSET))
    end = CAMERA.pixel((end_xy[0] + PLANE_OFFSET, end_xy[1] + PLANE_OFFSET))
    mouse_drag(page, start, end)


def _node_xy(page: Any, name: str) -> tuple[float, float] | None:
    return page.evaluate(
        """name => {
            const n = window.__viserMutable.nodeRefFromName[name];
            return n ? [n.position.x, n.position.y] : null;
        }""",
        name,
    )


def _wait_node(page: Any, name: str) -> None:
    page.wait_for_function(
        "name => name in window.__viserMutable.nodeRefFromName", arg=name
    )


def _shot(page: Any, name: str) -> None:
    folder = os.environ.get("CLASSROOM_SHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        settle(page, 5)
        page.screenshot(path=str(Path(folder) / f"{name}.png"))


def _explain_on_the_copy(planner: Any, seat: Any, page: Any, presenter: Any) -> None:
    """The copy explains the SVG (its own Explain folder): drawn in its page only."""
    page.get_by_text("Explain", exact=True).first.click()
    seat.explain.panel.choose("svg")
    _wait_node(page, f"{seat.explain.root}/explain/caption")
    _shot(page, "private_explain")
    assert planner.explain is None or planner.explain.explainer.method == "off"
    assert not presenter.evaluate(
        "() => Object.keys(window.__viserMutable.nodeRefFromName)"
        ".some(n => n.startsWith('/own_explain'))"
    )


def _one_panel_each(presenter: Any, watcher: Any) -> None:
    """The watcher's page draws the class's shared panel, the presenter's its own and
    not the class's (app.classroom.watch): one panel in each page."""
    for page in (presenter, watcher):
        radius = page.get_by_text("Radius [m]", exact=True)
        radius.first.wait_for()
        assert radius.count() == 1
    assert watcher.get_by_role("button", name="Make my own copy").count() == 1
    assert presenter.get_by_role("button", name="Make my own copy").count() == 0


def _close_to(a: Any, b: Any, tolerance: float) -> bool:
    return a is not None and bool(np.allclose(a, b, atol=tolerance))


def test_watcher_sees_the_presenter_drag_and_edits_only_its_own_copy(browser, planner):
    room, shared = planner.classroom, planner.controller
    tolerance = 3 * CAMERA.metres_per_pixel()
    with (
        open_page(planner, browser, url=planner.presenter_url, dpr=DPR) as pres,
        open_page(planner, browser, dpr=DPR) as watch,
    ):
        assert room.mode(pres.client.client_id) == "presenter"
        assert room.mode(watch.client.client_id) == "watching"
        _wait_node(pres.page, "/own/handles/goal")
        # Nobody but the presenter has a gizmo: none in the shared scope, none in the
        # watcher's; the watcher's goal is a plain frame under /shared.
        assert planner.server.scene._handle_from_transform_controls_name == {}
        assert watch.client.scene._handle_from_transform_controls_name == {}
        assert pres.client.scene._handle_from_transform_controls_name
        _one_panel_each(pres.page, watch.page)
        _shot(pres.page, "presenter")
        _shot(watch.page, "watcher")

        # The presenter drags it: the scene changes and the watcher's page shows it.
        goal = shared.scene.goal
        target = (9.0, 1.0)
        _drag(pres.page, goal, target)
        assert wait_until(lambda: shared.frame.dragging == frozenset(), 20)
        assert planner.wait_idle(20)
        moved = shared.scene.goal
        assert _close_to(moved, target, tolerance), moved
        assert wait_until(
            lambda: _close_to(
                _node_xy(watch.page, "/shared/handles/goal"), moved, 1e-3
            ),
            20,
        ), _node_xy(watch.page, "/shared/handles/goal")

        # The watcher makes its own copy (the button on its page) and drags its goal.
        watch.page.get_by_role("button", name="Make my own copy").click()
        sid = watch.client.client_id
        assert wait_until(lambda: room.mode(sid) == "private", 20)
        assert room.counts()["sessions"] == 1
        private = room.seat(sid).private
        assert private.wait_idle(60)
        _wait_node(watch.page, "/own/handles/goal")
        time.sleep(1.0)
        before_shared = shared.scene
        _shot(watch.page, "private_before")
        own_target = (2.0, 6.0)
        _drag(watch.page, moved, own_target)
        assert wait_until(
            lambda: _close_to(private.scene.goal, own_target, tolerance), 20
        ), private.scene.goal
        assert private.wait_idle(60)
        _shot(watch.page, "private")
        # The presenter's scene is unchanged.
        assert planner.wait_idle(20)
        assert shared.scene == before_shared
        _shot(pres.page, "presenter_after")
        threads = private.scheduler._threads
        _explain_on_the_copy(planner, room.seat(sid), watch.page, pres.page)

        # Another student, watching, tries to drag the goal with the mouse: nothing moves
        # (its mouse turns its camera: there is no gizmo to hold).
        with open_page(planner, browser, dpr=DPR) as other:
            assert room.mode(other.client.client_id) == "watching"
            goal, version = shared.scene.goal, shared.version
            _drag(other.page, goal, (5.0, 1.0))
            time.sleep(1.0)
            assert planner.wait_idle(20)
            assert shared.version == version and shared.scene.goal == goal
    # The copy's page is closed: its session is freed on the server.
    assert wait_until(lambda: room.seat(sid) is None, 20)
    assert room.counts()["sessions"] == 0
    assert wait_until(lambda: not any(t.is_alive() for t in threads), 20)
